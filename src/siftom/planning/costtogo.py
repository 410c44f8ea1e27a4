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
  chosen instances is carried as a bitmask and counted with ``popcount``.

With opening costs left out (``relaxed=True``) the value is the exact optimum of the relaxed
problem, a lower bound used as the A* heuristic. With them it is the cost of a concrete plan
and matches A* on the great majority of states (tests/planning measure this).
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from siftom.world.model import HELD, NOTHING, Action, Goal, State, World, apply, cost

INF = np.float64(1e9)
_ROW_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def goal_matrix(world: World, goals: Sequence[Goal]) -> np.ndarray:
    """Required counts, shape (len(goals), len(world.classes)); all goals share one target."""
    col = {c: k for k, c in enumerate(world.classes)}
    out = np.zeros((len(goals), len(world.classes)), dtype=np.int64)
    for g, goal in enumerate(goals):
        for c, n in goal.counts:
            if c not in col:
                raise KeyError(f"goal {goal.name!r} needs class {c!r}, which this world has no object of")
            out[g, col[c]] = n
    return out


@dataclass(frozen=True, eq=False)
class ClassTables:
    """Per-class tables for one arrangement of objects (agent position enters via ``delta``).

    cum[c, k]      cost of the k cheapest round trips of class c (INF if fewer exist)
    opens[c, k]    bitmask of closed containers among those k instances
    delta[c, q, k] first-trip correction when the agent starts at place q (<= 0)
    at_target[c]   objects of class c already on the target
    """

    cum: np.ndarray
    opens: np.ndarray
    delta: np.ndarray
    at_target: np.ndarray


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
        self._closable = np.array([p.closable for p in world.places])
        # class rows depend only on the world, target and kmax: share them across instances
        per_world = _ROW_CACHE.setdefault(world, {})
        self._cache = per_world.setdefault((target, self.kmax), {})

    # ----- tables ----------------------------------------------------------------------------
    def _class_rows(self, c: int, item_at: tuple[int, ...], open_mask: int):
        locs = tuple(item_at[i] for i in self._cls_items[c])
        relevant = 0
        for loc in locs:
            if loc >= 0 and self._closable[loc]:
                relevant |= 1 << loc
        key = (c, locs, open_mask & relevant)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        K, T = self.kmax, self.target
        avail = [loc for loc in locs if loc != HELD and loc != T]
        n_at_t = sum(1 for loc in locs if loc == T)
        cum = np.full(K + 1, INF)
        opens = np.zeros(K + 1, dtype=np.int64)
        delta = np.full((self.P, K + 1), INF)
        cum[0] = 0.0
        if avail:
            closed = [bool(self._closable[loc] and not (open_mask >> loc & 1)) for loc in avail]
            order = sorted(range(len(avail)), key=lambda j: (self._dT[avail[j]], closed[j]))
            L = np.array([avail[j] for j in order])
            w = 2.0 * self._dT[L] + 2.0
            bits = np.array([(1 << int(avail[j])) if closed[j] else 0 for j in order], dtype=np.int64)
            n = min(K, len(L))
            cum[1 : n + 1] = np.cumsum(w[:n])
            opens[1 : n + 1] = np.bitwise_or.accumulate(bits[:n])
            adj = self._d[:, L] - self._dT[L][None, :]  # (P, n_avail): first trip from q
            # best first trip among the k chosen: prefix minimum of adj
            pref = np.minimum.accumulate(adj, axis=1)
            # or swap in an unchosen instance j >= k as first: suffix min of (w + adj), minus w[k-1]
            wa = w[None, :] + adj
            suf = np.minimum.accumulate(wa[:, ::-1], axis=1)[:, ::-1]
            for k in range(1, n + 1):
                best = pref[:, k - 1]
                if k < len(L):
                    best = np.minimum(best, suf[:, k] - w[k - 1])
                delta[:, k] = best
        out = (cum, opens, delta, n_at_t)
        if len(self._cache) > 200_000:
            self._cache.clear()
        self._cache[key] = out
        return out

    def tables(self, s: State) -> ClassTables:
        """Build the per-class tables of state ``s``."""
        cum = np.empty((self.C, self.kmax + 1))
        opens = np.empty((self.C, self.kmax + 1), dtype=np.int64)
        delta = np.empty((self.C, self.P, self.kmax + 1))
        at_t = np.empty(self.C, dtype=np.int64)
        for c in range(self.C):
            cum[c], opens[c], delta[c], at_t[c] = self._class_rows(c, s.item_at, s.open_mask)
        return ClassTables(cum, opens, delta, at_t)

    def retable(self, base: ClassTables, s: State, classes: Sequence[int]) -> ClassTables:
        """Tables of ``s`` rebuilt only for ``classes`` (the others are unchanged from ``base``)."""
        if not len(classes):
            return base
        cum, opens, delta, at_t = base.cum.copy(), base.opens.copy(), base.delta.copy(), base.at_target.copy()
        for c in classes:
            cum[c], opens[c], delta[c], at_t[c] = self._class_rows(c, s.item_at, s.open_mask)
        return ClassTables(cum, opens, delta, at_t)

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
        (-1: empty hands). Padding entries have count 0 and so never contribute."""
        need = np.maximum(cnt - tabs.at_target[idx], 0)
        if np.ndim(held_cls) == 0 and held_cls < 0:
            holding = False
            deliver = np.zeros(len(idx), dtype=bool)
            eff = need
        else:
            hc = np.asarray(held_cls)
            holding = hc >= 0 if hc.ndim else True  # per row, or one agent for all rows
            hit = (idx == (hc[:, None] if hc.ndim else hc)) & (need > 0)
            deliver = hit.any(axis=1)
            eff = need - hit
        eff = np.minimum(eff, self.kmax)
        m = idx.shape[1]
        body = tabs.cum[idx, eff].sum(axis=1)
        if not relaxed:
            ob = tabs.opens[idx[:, 0], eff[:, 0]]
            for j in range(1, m):
                ob = ob | tabs.opens[idx[:, j], eff[:, j]]
            body = body + np.bitwise_count(ob.astype(np.uint64))
        pos = eff > 0
        any_need = pos.any(axis=1)
        # first-trip correction for goals that start where the agent stands: min over classes
        dq = tabs.delta[:, q, :]  # (C, Q, K+1)
        ft = np.where(pos[:, 0, None], dq[idx[:, 0], :, eff[:, 0]], INF)
        for j in range(1, m):
            ft = np.minimum(ft, np.where(pos[:, j, None], dq[idx[:, j], :, eff[:, j]], INF))
        ft = np.where(any_need[:, None], ft, 0.0).T  # (Q, G)
        if holding is False:
            out = body[None, :] + ft
        else:
            # an unneeded object is put down where the first fetch happens: one action
            other = (any_need & holding).astype(np.float64) + body
            out = np.where(deliver[None, :], (self._dT[q] + 1.0)[:, None] + body[None, :], other[None, :] + ft)
        return np.minimum(out, INF)

    def value(self, s: State, goal: Goal | np.ndarray, relaxed: bool = False) -> float:
        """V*(s; goal) for a single goal (convenience; slower than batched ``values``)."""
        N = goal_matrix(self.world, [goal]) if isinstance(goal, Goal) else np.atleast_2d(goal)
        return float(self.values(self.tables(s), N, s.agent_at[self.agent], s.held[self.agent], relaxed)[0])


@dataclass(frozen=True, eq=False)
class SparseGoals:
    """Goals as (class index, count) lists padded to equal length (padding: count 0).

    Goals name few classes each, so this is several times smaller than the dense matrix.
    """

    idx: np.ndarray
    cnt: np.ndarray
    n_classes: int

    @classmethod
    def from_dense(cls, N: np.ndarray) -> SparseGoals:
        N = np.atleast_2d(N)
        G, C = N.shape
        nz = N > 0
        m = max(int(nz.sum(axis=1).max()) if G else 0, 1)
        # stable sort puts each row's nonzero columns first, in column order
        order = np.argsort(~nz, axis=1, kind="stable")[:, :m]
        cnt = np.take_along_axis(N, order, axis=1).astype(np.int64)
        idx = np.where(cnt > 0, order, 0).astype(np.int64)  # padding: any class with count 0
        return cls(idx, np.where(cnt > 0, cnt, 0), C)

    def subset(self, rows: np.ndarray) -> SparseGoals:
        return SparseGoals(self.idx[rows], self.cnt[rows], self.n_classes)

    def __len__(self) -> int:
        return len(self.idx)


def successor_values(
    ctg: CostToGo, s: State, tabs: ClassTables, actions: Sequence[Action], N: np.ndarray | SparseGoals
) -> np.ndarray:
    """Q*(s, a; g) = cost(a) + V*(s_a; g) for every action (rows) and goal (columns).

    Two batched evaluations per state. Walks share ``tabs`` and differ only in where the agent
    stands. Every other action changes the tables of at most a few classes (one object's class,
    or the classes inside one container): their rebuilt rows are appended to the tables and the
    goals of that action point at them, so all such successors are evaluated in one call. A grab
    only changes goals that need the grabbed class; the others pay exactly one extra ``put``.
    """
    sp = N if isinstance(N, SparseGoals) else SparseGoals.from_dense(N)
    world, agent, C = ctg.world, ctg.agent, ctg.C
    here, held = s.agent_at[agent], s.held[agent]
    held_cls = int(world.item_class_idx[held]) if held != NOTHING else -1
    G = len(sp)
    Q = np.empty((len(actions), G))
    walk_rows = [r for r, a in enumerate(actions) if a.kind == "walk"]
    places = np.array([here] + [actions[r].place for r in walk_rows])
    v = ctg._values(tabs, sp.idx, sp.cnt, places, held_cls)
    v_stay = v[0]
    if walk_rows:
        Q[walk_rows] = v[1:] + world.dist[here, places[1:]][:, None]
    others = [r for r, a in enumerate(actions) if a.kind != "walk"]
    if not others:
        return Q
    extra_rows: list[tuple] = []  # appended table rows
    parts_idx, parts_cnt, parts_held, owners = [], [], [], []
    need = None
    for r in others:
        a = actions[r]
        s2 = apply(s, a)
        if a.kind in ("grab", "put", "handover"):
            changed = [int(world.item_class_idx[a.obj])]
        else:  # open/close: classes with objects in that container
            changed = sorted({int(world.item_class_idx[i]) for i, loc in enumerate(s.item_at) if loc == a.place})
        idx = sp.idx
        rows = None
        if a.kind == "grab" and held == NOTHING:
            if need is None:
                need = np.maximum(sp.cnt - tabs.at_target[sp.idx], 0)
                any_need = (need > 0).any(axis=1)  # goals not yet reached
            c = changed[0]
            # goals that name class c are recomputed (taking one off the target can undo them);
            # the others gain exactly one more put later
            rows = np.flatnonzero(((sp.idx == c) & (sp.cnt > 0)).any(axis=1))
            Q[r] = 1.0 + v_stay + any_need
            if not len(rows):
                continue
            idx = sp.idx[rows]
        remap = {}
        for c in changed:
            remap[c] = C + len(extra_rows)
            extra_rows.append(ctg._class_rows(c, s2.item_at, s2.open_mask))
        cnt = sp.cnt if rows is None else sp.cnt[rows]
        if remap:
            idx = idx.copy()
            for c, c2 in remap.items():
                idx[idx == c] = c2
        h2 = s2.held[agent]
        hc2 = -1 if h2 == NOTHING else remap.get(int(world.item_class_idx[h2]), int(world.item_class_idx[h2]))
        parts_idx.append(idx)
        parts_cnt.append(cnt)
        parts_held.append(np.full(len(idx), hc2, dtype=np.int64))
        owners.append((r, rows, float(cost(world, s, a))))
    if not parts_idx:
        return Q
    if extra_rows:
        cum = np.concatenate([tabs.cum, np.stack([e[0] for e in extra_rows])])
        opens = np.concatenate([tabs.opens, np.stack([e[1] for e in extra_rows])])
        delta = np.concatenate([tabs.delta, np.stack([e[2] for e in extra_rows])])
        at_t = np.concatenate([tabs.at_target, np.array([e[3] for e in extra_rows], dtype=np.int64)])
        big = ClassTables(cum, opens, delta, at_t)
    else:
        big = tabs
    vals = ctg._values(big, np.concatenate(parts_idx), np.concatenate(parts_cnt), np.array([here]),
                       np.concatenate(parts_held))[0]
    k = 0
    for (r, rows, c_a), idx in zip(owners, parts_idx, strict=True):
        n = len(idx)
        if rows is None:
            Q[r] = c_a + vals[k:k + n]
        else:
            Q[r, rows] = c_a + vals[k:k + n]
        k += n
    return Q
