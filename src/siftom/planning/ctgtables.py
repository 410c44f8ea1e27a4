"""The arrays the fast cost-to-go (:mod:`siftom.planning.costtogo`) works on.

Goals as a dense count matrix or as padded sparse (class, count) lists, and the per-class tables
of one arrangement of objects, with the order in which the tables take a class's objects.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from siftom.errors import ObservationError
from siftom.world.model import Goal, World

INF = np.float64(1e9)

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
Bool = npt.NDArray[np.bool_]
# one class's table rows (``CostToGo._class_rows``): cum, opens, delta, fdelta, fmask, the number
# already on the target, then the five arrays again with a leading axis of length one
ClassRows = tuple[F64, I64, F64, F64, I64, int, F64, I64, F64, F64, I64]


def goal_matrix(world: World, goals: Sequence[Goal]) -> np.ndarray:
    """Required counts, shape (len(goals), len(world.classes)); all goals share one target."""
    col = {c: k for k, c in enumerate(world.classes)}
    out = np.zeros((len(goals), len(world.classes)), dtype=np.int64)
    for g, goal in enumerate(goals):
        for c, n in goal.counts:
            if c not in col:
                raise ObservationError(
                    f"goal {goal.name!r} needs class {c!r}, which this world has no object of; "
                    f"add such an object to the world or drop the goal (classes here: {', '.join(world.classes)})")
            out[g, col[c]] = n
    return out


@dataclass(frozen=True, eq=False)
class ClassTables:
    """Per-class tables for one arrangement of objects (agent position enters via the deltas).

    cum[c, k]       cost of the k cheapest round trips of class c (INF if fewer exist)
    opens[c, k]     bitmask of closed containers among those k instances (ties in distance
                    are broken towards open places, then towards the containers holding most)
    delta[c, k, q]  first-trip correction when the agent starts at place q, opening costs left
                    out (the relaxed problem: exact, used by the A* heuristic)
    fdelta[c, k, q] first-trip correction with opening costs: the first object may come from a
                    container the k cheapest round trips would not open (and then one of those
                    is left out); the change in walking and grabbing, opening not included
    fmask[c, k, q]  the closed containers that choice opens (replaces ``opens[c, k]``)
    at_target[c]    objects of class c already on the target

    Rows are stored so that (class, k) pairs index flat arrays: one ``take`` per table.
    """

    cum: np.ndarray
    opens: np.ndarray
    delta: np.ndarray
    fdelta: np.ndarray
    fmask: np.ndarray
    at_target: np.ndarray

    def extend(self, rows: Sequence[ClassRows], relaxed: bool = False) -> ClassTables:
        """These tables with class rows (``CostToGo._class_rows`` results) appended after them.

        Without ``relaxed`` the result serves full values only (its ``delta`` is left empty: one
        copy less on the hot path)."""
        if not rows:
            return self
        fields = ("cum", "opens", "delta", "fdelta", "fmask")
        cum, opens, delta, fdelta, fmask = [
            np.concatenate([getattr(self, f)] + [r[6 + k] for r in rows]) if relaxed or f != "delta"
            else self.delta[:0] for k, f in enumerate(fields)]
        return ClassTables(cum, opens, delta, fdelta, fmask,
                           np.concatenate([self.at_target, np.array([r[5] for r in rows], dtype=np.int64)]))


def fetch_order(sites: Sequence[int], size: dict[int, int], closed: dict[int, bool], dT: np.ndarray) -> list[int]:
    """Locations of a class's objects (one entry per object) in the order the tables take them.

    By round trip (distance to the target) first; within a distance, open places before closed
    containers and bigger groups before smaller ones, so that every prefix opens as few
    containers as possible.
    """
    order = sorted(sites, key=lambda u: (dT[u], closed[u], -size[u], u))
    return [u for u in order for _ in range(size[u])]


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

    @property
    def all_rows(self) -> np.ndarray:
        cache: dict[int | str, npt.NDArray[np.intp]] = self.__dict__.setdefault("_rows_naming", {})
        if "all" not in cache:
            cache["all"] = np.arange(len(self.idx))
        return cache["all"]

    def rows_naming(self, c: int) -> np.ndarray:
        """Indices of the goals that ask for class ``c`` (cached per instance)."""
        cache: dict[int | str, npt.NDArray[np.intp]] = self.__dict__.setdefault("_rows_naming", {})
        if c not in cache:
            cache[c] = np.flatnonzero(((self.idx == c) & (self.cnt > 0)).any(axis=1))
        return cache[c]

    def __len__(self) -> int:
        return len(self.idx)
