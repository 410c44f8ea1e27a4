"""Fast cost-to-go for fetch-and-place goals, vectorised over many goals at once.

The inference needs V*(s; g) and Q*(s, a; g) = cost(a) + V*(s'; g) for every observed step,
every action available there and every goal hypothesis: thousands of values per inference.
Searching for each is far too slow, so this module exploits the structure of the goals
(docs/planning.md has the derivation):

* An agent carries one object at a time, so after handling what it holds, every remaining
  object is fetched by a round trip ``target -> l_i -> target`` costing ``2 d(T, l_i) + 2``
  (walks plus grab and put), except the first trip, which starts where the agent stands:
  ``d(q, l_i) + d(l_i, T) + 2``.
* Hence, per object class, the best ``k`` instances are the ``k`` cheapest round trips, and
  the first-trip correction is a minimum over one instance. Both are tabulated per class for
  every ``k`` and every standing place ``q``; a goal's value is then a gather and a sum.
* Closed containers cost one ``open`` the first time; the union of containers to open over the
  chosen instances is carried as a bitmask and counted with ``popcount``. The first object may
  come from a container the round trips would not open: per class and place, the first-trip
  choice is made with its openings counted (``fdelta``, ``fmask``).
* A needed object in hand is delivered first, or put down and left when the rest is cheaper.

With opening costs left out (``relaxed=True``) the value is the exact optimum of the relaxed
problem, a lower bound used as the A* heuristic. With them it is the cost of a concrete plan;
it equals A* on every state of the built-in scenarios (recipes/costtogo_scenarios.py) and
can be a step over where two classes could share a container (docs/planning.md).
"""

from __future__ import annotations

import operator
import weakref
from collections.abc import Sequence
from typing import Any

import numpy as np

from siftom.planning import _kernel
from siftom.planning.ctgtables import F64, Bool, ClassRows
from siftom.planning.ctgtables import INF as INF
from siftom.planning.ctgtables import ClassTables as ClassTables
from siftom.planning.ctgtables import SparseGoals as SparseGoals
from siftom.planning.ctgtables import fetch_order as fetch_order
from siftom.planning.ctgtables import goal_matrix as goal_matrix
from siftom.world.model import HELD, NOTHING, Action, Goal, State, World, apply, cost

RowKey = tuple[int, tuple[int, ...], int]

# per world: class rows by (target, kmax), tables by (target, kmax, agent, "tables")
_ROW_CACHE: weakref.WeakKeyDictionary[World, dict[tuple[object, ...], dict[Any, Any]]] = weakref.WeakKeyDictionary()


class CostToGo:
    """V*(s; g) for one agent and a fixed target, vectorised over goals.

    Args:
        world: the static world.
        target: place index where goal objects must end up.
        kmax: largest count any goal asks for (tables are built up to it).
        agent: whose cost-to-go (the other agent's held object is unavailable).
    """

    def __init__(self, world: World, target: int, kmax: int, agent: int = 0) -> None:
        self.world = world
        self.target = target
        self.kmax = int(kmax)
        self.agent = agent
        self.C = len(world.classes)
        self.P = len(world.places)
        d = world.dist.astype(np.float64)
        self._dT = d[:, target]  # d(l, T)
        self._d = d
        self._cls_items = [np.flatnonzero(world.item_class_idx == c) for c in range(self.C)]
        # fast "positions of this class's objects" as a tuple (itemgetter of one index
        # returns a scalar, so wrap it)
        self._cls_locs = [
            (operator.itemgetter(*map(int, ix)) if len(ix) > 1 else
             (lambda t, i=int(ix[0]): (t[i],)) if len(ix) == 1 else (lambda t: ()))
            for ix in self._cls_items
        ]
        self._closable = np.array([p.closable for p in world.places])
        # class rows depend only on the world, target and kmax: share them across instances
        per_world = _ROW_CACHE.setdefault(world, {})
        self._cache: dict[RowKey, ClassRows] = per_world.setdefault((target, self.kmax), {})
        # values at every place by (goals, hand, objects, containers); kept small
        self._vcache: dict[tuple[int, int, tuple[int, ...], int], tuple[SparseGoals, np.ndarray]] = {}
        # whole tables by state (tables are never modified in place)
        self._tables: dict[State, ClassTables] = per_world.setdefault((target, self.kmax, agent, "tables"), {})

    def clear_state_cache(self) -> None:
        """Forget the per-state tables and values (benchmarks call this to time work from scratch)."""
        self._tables.clear()
        self._vcache.clear()

    # ----- tables ----------------------------------------------------------------------------
    def _class_rows(self, c: int, item_at: tuple[int, ...], open_mask: int) -> ClassRows:
        locs = self._cls_locs[c](item_at)
        hit = self._cache.get((c, locs, open_mask))
        if hit is not None:
            return hit
        relevant = 0
        for loc in locs:
            if loc >= 0 and self._closable[loc]:
                relevant |= 1 << loc
        key = (c, locs, open_mask & relevant)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache[(c, locs, open_mask)] = hit
            return hit
        K, T = self.kmax, self.target
        avail = [loc for loc in locs if loc != HELD and loc != T]
        n_at_t = sum(1 for loc in locs if loc == T)
        cum = np.full(K + 1, INF)
        opens = np.zeros(K + 1, dtype=np.int64)
        delta = np.full((K + 1, self.P), INF)
        fdelta = np.full((K + 1, self.P), INF)
        fmask = np.zeros((K + 1, self.P), dtype=np.int64)
        cum[0] = 0.0
        if avail:
            sites = sorted(set(avail))
            size = {u: avail.count(u) for u in sites}
            closed = {u: bool(self._closable[u] and not (open_mask >> u & 1)) for u in sites}
            seq = fetch_order(sites, size, closed, self._dT)
            n = min(K, len(seq))
            L = np.array(seq[:n])
            w = 2.0 * self._dT[L] + 2.0
            bits = np.array([(1 << u) if closed[u] else 0 for u in seq[:n]], dtype=np.int64)
            cum[1 : n + 1] = np.cumsum(w)
            opens[1 : n + 1] = np.bitwise_or.accumulate(bits)
            pop = np.bitwise_count(opens[1 : n + 1].view(np.uint64)).astype(np.float64)
            # The first trip starts where the agent stands. For each place u the first object
            # may come from, the other k - 1 are the cheapest of the rest (u's container is then
            # open for them): walking + grabbing W_u[k], containers m_u[k]. Relaxed: the best u
            # by walking alone; full: by walking plus the containers this class opens.
            best = np.full((n, self.P), np.inf)
            for u in dict.fromkeys(seq):
                size_u = dict(size)
                size_u[u] -= 1
                rest = fetch_order(sites, size_u, {**closed, u: False}, self._dT)[: n - 1]
                w_rest = 2.0 * self._dT[np.array(rest, dtype=np.int64)] + 2.0
                W_u = 2.0 * self._dT[u] + 2.0 + np.concatenate([[0.0], np.cumsum(w_rest)])
                b_rest = np.array([(1 << v) if closed[v] and v != u else 0 for v in rest], dtype=np.int64)
                m_u = ((1 << u) if closed[u] else 0) | np.concatenate(
                    [np.zeros(1, dtype=np.int64), np.bitwise_or.accumulate(b_rest)])
                rel = (W_u - cum[1 : n + 1])[:, None] + (self._d[:, u] - self._dT[u])[None, :]  # (n, P)
                np.minimum(delta[1 : n + 1], rel, out=delta[1 : n + 1])
                tot = rel + (np.bitwise_count(m_u.view(np.uint64)) - pop)[:, None]
                better = tot < best  # ties keep the earlier place: the cheapest round trips first
                best = np.where(better, tot, best)
                fdelta[1 : n + 1] = np.where(better, rel, fdelta[1 : n + 1])
                fmask[1 : n + 1] = np.where(better, m_u[:, None], fmask[1 : n + 1])
        # rows are also kept with a leading axis, ready to append to a table in one concatenate
        out = (cum, opens, delta, fdelta, fmask, n_at_t, cum[None], opens[None], delta[None], fdelta[None], fmask[None])
        if len(self._cache) > 200_000:
            self._cache.clear()
        self._cache[key] = self._cache[(c, locs, open_mask)] = out
        return out

    def tables(self, s: State) -> ClassTables:
        """The per-class tables of state ``s`` (a function of the state alone: cached)."""
        hit = self._tables.get(s)
        if hit is None:
            hit = self._build_tables(s)
            if len(self._tables) > 4096:
                self._tables.clear()
            self._tables[s] = hit
        return hit

    def _build_tables(self, s: State) -> ClassTables:
        rows = [self._class_rows(c, s.item_at, s.open_mask) for c in range(self.C)]
        cum, opens, delta, fdelta, fmask = (np.stack([r[k] for r in rows]) for k in range(5))
        return ClassTables(cum, opens, delta, fdelta, fmask, np.array([r[5] for r in rows], dtype=np.int64))

    def retable(self, base: ClassTables, s: State, classes: Sequence[int]) -> ClassTables:
        """Tables of ``s`` rebuilt only for ``classes`` (the others are unchanged from ``base``)."""
        if not len(classes):
            return base
        hit = self._tables.get(s)
        if hit is not None:
            return hit
        arrays = [base.cum.copy(), base.opens.copy(), base.delta.copy(), base.fdelta.copy(), base.fmask.copy(),
                  base.at_target.copy()]
        for c in classes:
            row = self._class_rows(c, s.item_at, s.open_mask)
            for k, arr in enumerate(arrays):
                arr[c] = row[k]
        out = ClassTables(*arrays)
        if len(self._tables) > 4096:
            self._tables.clear()
        self._tables[s] = out
        return out

    # ----- values ----------------------------------------------------------------------------
    def values(
        self, tabs: ClassTables, N: np.ndarray | SparseGoals, at: np.ndarray | int, held: int,
        relaxed: bool = False,
    ) -> np.ndarray:
        """V for goals ``N`` (G, C) with the agent at place(s) ``at`` holding ``held``.

        Returns shape (G,) for a scalar ``at`` or (len(at), G) for an array of places.
        """
        sp = N if isinstance(N, SparseGoals) else SparseGoals.from_dense(N)
        hc = int(self.world.item_class_idx[held]) if held != NOTHING else -1
        out = self._values(tabs, sp.idx, sp.cnt, np.atleast_1d(np.asarray(at, dtype=np.int64)), hc, relaxed)
        return out[0] if np.ndim(at) == 0 else out

    def _values(self, tabs: ClassTables, idx: np.ndarray, cnt: np.ndarray, q: np.ndarray,
                held_cls: np.ndarray | int, relaxed: bool = False) -> np.ndarray:
        """Core of :meth:`values`: rows (idx, cnt) index table rows; ``held_cls`` per row or scalar
        (-1: empty hands). Padding entries have count 0 and so never contribute. Counts never
        exceed ``kmax`` (the tables are built up to the largest count). With numba installed
        (``siftom[fast]``), one compiled loop does the same work (planning/_kernel.py)."""
        K1 = self.kmax + 1
        if relaxed and len(tabs.delta) != len(tabs.cum):
            raise ValueError("these tables were extended for full values only; extend(..., relaxed=True)")
        # work in (m, G) layout: reductions over a goal's few classes run over the first axis
        idx = np.ascontiguousarray(idx.T)
        cnt = np.ascontiguousarray(cnt.T)
        if _kernel.AVAILABLE:
            held = (np.full(idx.shape[1], held_cls, dtype=np.int64) if np.ndim(held_cls) == 0
                    else np.ascontiguousarray(held_cls, dtype=np.int64))
            return _kernel.values_kernel(
                tabs.cum.reshape(-1), tabs.opens.reshape(-1), tabs.delta.reshape(-1, self.P),
                tabs.fdelta.reshape(-1, self.P), tabs.fmask.reshape(-1, self.P), tabs.at_target,
                self._dT, idx, cnt, np.ascontiguousarray(q, dtype=np.int64), held, K1, bool(relaxed), float(INF))
        need = cnt - tabs.at_target[idx]
        np.maximum(need, 0, out=need)
        if np.ndim(held_cls) == 0 and held_cls < 0:
            body, ft, _any, _bits = self._trips(tabs, idx * K1 + need, need > 0, q, relaxed)
            return np.minimum(body[None, :] + ft, INF)
        hc = np.asarray(held_cls)
        holding = hc >= 0 if hc.ndim else True  # per row, or one agent for all rows
        hit = (idx == (hc[None, :] if hc.ndim else hc)) & (need > 0)
        deliver = hit.any(axis=0)
        eff = need - hit
        body, ft, any_need, bits = self._trips(tabs, idx * K1 + eff, eff > 0, q, relaxed)
        # an unneeded object is put down where the first fetch happens: one action
        other = (any_need & holding) + body
        # a needed one is delivered first (then round trips only), or put down here and left
        # when the rest is cheaper without it (an object carried from far away)
        dval = (self._dT[q] + 1.0)[:, None] + (body + bits)[None, :]
        if deliver.any():
            body2, ft2, _any, _bits = self._trips(tabs, idx * K1 + need, need > 0, q, relaxed)
            dval = np.minimum(dval, 1.0 + body2[None, :] + ft2)
        out: F64 = np.where(deliver[None, :], dval, other[None, :] + ft)
        return np.minimum(out, INF)

    def _trips(self, tabs: ClassTables, flat: np.ndarray, pos: np.ndarray, q: np.ndarray,
               relaxed: bool) -> tuple[F64, F64, Bool, F64]:
        """Round trips (G,), first-trip term from each place (Q, G), whether anything is needed
        (G,) and the containers the round trips alone open (G,), for (m, G) row indices."""
        body: F64 = tabs.cum.reshape(-1).take(flat).sum(axis=0)
        any_need: Bool = np.any(pos, axis=0)
        # first trip from where the agent stands: min over the classes the goal still needs
        if relaxed:
            dl = tabs.delta.reshape(-1, self.P)[:, q].take(flat, axis=0)  # (m, G, Q)
            bits: F64 = np.zeros_like(body)
        else:
            # the containers the other classes open, and this class's own with its first trip
            ow = tabs.opens.reshape(-1).take(flat)  # (m, G)
            pre = np.bitwise_or.accumulate(ow, axis=0)
            suf = np.bitwise_or.accumulate(ow[::-1], axis=0)[::-1]
            zero = np.zeros((1, ow.shape[1]), dtype=np.int64)
            others = np.concatenate([zero, pre[:-1]]) | np.concatenate([suf[1:], zero])
            fm = tabs.fmask.reshape(-1, self.P)[:, q].take(flat, axis=0)  # (m, G, Q)
            dl = tabs.fdelta.reshape(-1, self.P)[:, q].take(flat, axis=0) + np.bitwise_count(
                (others[:, :, None] | fm).view(np.uint64))
            bits = np.bitwise_count(pre[-1].view(np.uint64)).astype(np.float64)
        ft: F64 = np.where(pos[:, :, None], dl, INF).min(axis=0).T  # (Q, G)
        ft[:, ~any_need] = 0.0
        return body, ft, any_need, bits

    def value(self, s: State, goal: Goal | np.ndarray, relaxed: bool = False) -> float:
        """V*(s; goal) for a single goal (convenience; slower than batched ``values``)."""
        N = goal_matrix(self.world, [goal]) if isinstance(goal, Goal) else np.atleast_2d(goal)
        return float(self.values(self.tables(s), N, s.agent_at[self.agent], s.held[self.agent], relaxed)[0])


def successor_values(
    ctg: CostToGo, s: State, tabs: ClassTables, actions: Sequence[Action], N: np.ndarray | SparseGoals
) -> np.ndarray:
    """Q*(s, a; g) = cost(a) + V*(s_a; g) for every action (rows) and goal (columns).

    Two batched evaluations per state. Walks share ``tabs`` and differ only in where the agent
    stands. Every other action changes the tables of at most a few classes (one object's class,
    or the classes inside one container); goals that name none of them follow in closed form
    from standing still, and for the rest the rebuilt rows are appended to the tables and those
    goals point at them, so all such successors are evaluated in one call.
    """
    sp = N if isinstance(N, SparseGoals) else SparseGoals.from_dense(N)
    world, agent, C = ctg.world, ctg.agent, ctg.C
    here = s.agent_at[agent]
    Q = np.empty((len(actions), len(sp)))
    v_stay = _walk_values(ctg, s, tabs, actions, sp, Q)
    others = [r for r, a in enumerate(actions) if a.kind != "walk"]
    if not others:
        return Q
    extra_rows: list[ClassRows] = []  # appended table rows
    parts_idx, parts_cnt, parts_held, owners = [], [], [], []
    any_need = grab_base = None
    for r in others:
        a = actions[r]
        s2 = apply(s, a)
        if a.kind in ("grab", "put", "handover"):
            changed = [int(world.item_class_idx[a.obj])]
        else:  # open/close: classes with objects in that container
            changed = sorted({int(world.item_class_idx[i]) for i, loc in enumerate(s.item_at) if loc == a.place})
        if any_need is None:
            need = np.maximum(sp.cnt - tabs.at_target[sp.idx], 0)
            any_need = (need > 0).any(axis=1)  # goals not yet reached
        # Goals that name none of the changed classes see the same tables, place and (for them)
        # an equally useless object in hand: a grab adds one later put, a put or handover
        # removes it, an open or close changes nothing. Only the others are recomputed.
        if len(changed) == 1:
            if a.kind == "grab":
                if grab_base is None:
                    grab_base = 1.0 + v_stay + any_need
                Q[r] = grab_base
            elif a.kind in ("put", "handover"):
                Q[r] = 1.0 + v_stay - any_need
            else:
                Q[r] = 1.0 + v_stay
            rows = sp.rows_naming(changed[0])
            if not len(rows):
                continue
        else:  # a container with several classes (or none): recompute every goal
            rows = sp.all_rows
        idx = sp.idx[rows]
        remap = {}
        for c in changed:
            remap[c] = C + len(extra_rows)
            extra_rows.append(ctg._class_rows(c, s2.item_at, s2.open_mask))
        cnt = sp.cnt[rows]
        if len(remap) == 1:
            (c, c2), = remap.items()
            idx = np.where(idx == c, c2, idx)
        elif remap:
            lut = np.arange(C + len(extra_rows))
            lut[list(remap)] = list(remap.values())
            idx = lut[idx]
        h2 = s2.held[agent]
        hc2 = -1 if h2 == NOTHING else remap.get(int(world.item_class_idx[h2]), int(world.item_class_idx[h2]))
        parts_idx.append(idx)
        parts_cnt.append(cnt)
        parts_held.append(np.full(len(idx), hc2, dtype=np.int64))
        owners.append((r, rows, float(cost(world, s, a))))
    if parts_idx:
        vals = ctg._values(tabs.extend(extra_rows), np.concatenate(parts_idx), np.concatenate(parts_cnt),
                           np.array([here]), np.concatenate(parts_held))[0]
        k = 0
        for (r, rows, c_a), idx in zip(owners, parts_idx, strict=True):
            n = len(idx)
            Q[r, rows] = c_a + vals[k:k + n]
            k += n
    return Q


def _walk_values(ctg: CostToGo, s: State, tabs: ClassTables, actions: Sequence[Action], sp: SparseGoals,
                 Q: np.ndarray) -> np.ndarray:
    """Fill the rows of ``Q`` that are walks; returns V where the agent stands, per goal."""
    world, agent = ctg.world, ctg.agent
    here, held = s.agent_at[agent], s.held[agent]
    held_cls = int(world.item_class_idx[held]) if held != NOTHING else -1
    walk_rows = [r for r, a in enumerate(actions) if a.kind == "walk"]
    places = np.array([here] + [actions[r].place for r in walk_rows])
    # V at every place depends on the objects, containers and hand, not on where the agent
    # came from: after a walk, the next state's walk successors are the same states again
    key = (id(sp), s.held[agent], s.item_at, s.open_mask)
    v_all = ctg._vcache.get(key)
    if v_all is None or v_all[0] is not sp:
        v_all = (sp, ctg._values(tabs, sp.idx, sp.cnt, np.arange(ctg.P), held_cls))
        if len(ctg._vcache) > 256:
            ctg._vcache.clear()
        ctg._vcache[key] = v_all
    v = v_all[1][places]
    if walk_rows:
        Q[walk_rows] = v[1:] + world.dist[here, places[1:]][:, None]
    v_stay: np.ndarray = v[0]
    return v_stay
