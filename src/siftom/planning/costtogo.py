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
        scalar = np.ndim(at) == 0
        q = np.atleast_1d(np.asarray(at, dtype=np.int64))
        idx, cnt = sp.idx, sp.cnt
        C = self.C
        pad = idx == C  # padding columns point past the last class
        cidx = np.where(pad, 0, idx)
        need = np.where(pad, 0, np.maximum(cnt - tabs.at_target[cidx], 0))
        if held != NOTHING:
            ch = int(self.world.item_class_idx[held])
            hit = (idx == ch) & (need > 0)
            deliver = hit.any(axis=1)
            eff = need - hit
        else:
            deliver = np.zeros(len(idx), dtype=bool)
            eff = need
        over = (eff > self.kmax).any(axis=1)
        eff_c = np.minimum(eff, self.kmax)
        m = idx.shape[1]
        cum = tabs.cum[cidx, eff_c]
        body = cum.sum(axis=1)
        body = np.where(over, INF, body)
        if not relaxed and m:
            ob = tabs.opens[cidx[:, 0], eff_c[:, 0]]
            for j in range(1, m):
                ob = ob | tabs.opens[cidx[:, j], eff_c[:, j]]
            body = body + np.bitwise_count(ob.astype(np.uint64)).astype(np.float64)
        any_need = (eff > 0).any(axis=1)
        # first-trip correction for goals that start where the agent stands: min over classes
        dq = tabs.delta[:, q, :]  # (C, Q, K+1)
        ft = np.full((len(q), len(idx)), INF)
        for j in range(m):
            dj = dq[cidx[:, j], :, eff_c[:, j]]  # (G, Q)
            dj = np.where((eff[:, j] > 0)[:, None], dj, INF)
            ft = np.minimum(ft, dj.T)
        ft = np.where(any_need[None, :], ft, 0.0)
        base_deliver = self._dT[q][:, None] + 1.0  # walk to T and put
        # an unneeded object is put down where the first fetch happens: one action
        base_other = np.where(any_need, 1.0, 0.0)[None, :] if held != NOTHING else 0.0
        out = np.where(deliver[None, :], base_deliver + body[None, :], base_other + body[None, :] + ft)
        out = np.minimum(out, INF)
        return out[0] if scalar else out

    def value(self, s: State, goal: Goal | np.ndarray, relaxed: bool = False) -> float:
        """V*(s; goal) for a single goal (convenience; slower than batched ``values``)."""
        N = goal_matrix(self.world, [goal]) if isinstance(goal, Goal) else np.atleast_2d(goal)
        return float(self.values(self.tables(s), N, s.agent_at[self.agent], s.held[self.agent], relaxed)[0])


@dataclass(frozen=True, eq=False)
class SparseGoals:
    """Goals as (class index, count) lists padded to equal length (padding index = n_classes).

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
        idx = np.where(cnt > 0, order, C).astype(np.int64)
        return cls(idx, np.where(cnt > 0, cnt, 0), C)

    def subset(self, rows: np.ndarray) -> SparseGoals:
        return SparseGoals(self.idx[rows], self.cnt[rows], self.n_classes)

    def __len__(self) -> int:
        return len(self.idx)


def successor_values(
    ctg: CostToGo, s: State, tabs: ClassTables, actions: Sequence[Action], N: np.ndarray | SparseGoals
) -> np.ndarray:
    """Q*(s, a; g) = cost(a) + V*(s_a; g) for every action (rows) and goal (columns).

    Walk actions share ``tabs`` and are evaluated in one batch (together with standing still).
    A grab changes only its object's class: goals that do not need that class pay exactly one
    extra ``put`` later, so only the goals that need it are recomputed. Other actions change at
    most the classes of one object or one container, so only those tables are rebuilt.
    """
    sp = N if isinstance(N, SparseGoals) else SparseGoals.from_dense(N)
    world, agent = ctg.world, ctg.agent
    here, held = s.agent_at[agent], s.held[agent]
    Q = np.empty((len(actions), len(sp)))
    walk_rows = [r for r, a in enumerate(actions) if a.kind == "walk"]
    places = np.array([here] + [actions[r].place for r in walk_rows])
    v = ctg.values(tabs, sp, places, held)
    v_stay = v[0]
    if walk_rows:
        Q[walk_rows] = v[1:] + world.dist[here, places[1:]][:, None]
    any_need = None
    for r, a in enumerate(actions):
        if a.kind == "walk":
            continue
        s2 = apply(s, a)
        if a.kind in ("grab", "put", "handover"):
            changed = [int(world.item_class_idx[a.obj])]
        else:  # open/close: classes with objects in that container
            changed = sorted({int(world.item_class_idx[i]) for i, loc in enumerate(s.item_at) if loc == a.place})
        t2 = ctg.retable(tabs, s2, changed)
        if a.kind == "grab" and held == NOTHING:
            c = changed[0]
            if any_need is None:
                need = np.where(sp.idx == ctg.C, 0, sp.cnt - tabs.at_target[np.minimum(sp.idx, ctg.C - 1)])
                any_need = (need > 0).any(axis=1)
                needs_cls = {}
            if c not in needs_cls:
                needs_cls[c] = np.flatnonzero(((sp.idx == c) & (need > 0)).any(axis=1))
            rows = needs_cls[c]
            out = v_stay + any_need
            if len(rows):
                out[rows] = ctg.values(t2, sp.subset(rows), s2.agent_at[agent], s2.held[agent])
            Q[r] = 1.0 + out
            continue
        Q[r] = cost(world, s, a) + ctg.values(t2, sp, s2.agent_at[agent], s2.held[agent])
    return Q
