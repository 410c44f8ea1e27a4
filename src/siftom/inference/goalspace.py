"""What inference needs of a world and a goal space, built once and shared: the goals as count
rows, the human subgoals (a goal minus the robot's part) and the cost-to-go over them."""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from siftom.planning.costtogo import CostToGo, SparseGoals, goal_matrix
from siftom.world.model import HUMAN, Action, Goal, State, World


def changed_classes(world: World, s: State, action: Action) -> list[int]:
    """Object classes whose cost tables an action changes."""
    if action.kind in ("grab", "put", "handover"):
        return [int(world.item_class_idx[action.obj])]
    if action.kind in ("open", "close"):
        return sorted({int(world.item_class_idx[i]) for i, loc in enumerate(s.item_at) if loc == action.place})
    return []


@dataclass(frozen=True, eq=False)
class GoalSpace:
    """What depends only on the world and the goal space: built once, shared by inferences."""

    N: np.ndarray
    sp_goal: SparseGoals
    sp: SparseGoals
    pair_goal: np.ndarray
    pair_cls: np.ndarray
    pair_row: np.ndarray
    class_total: np.ndarray
    ctg: CostToGo


_GOAL_SPACES: weakref.WeakKeyDictionary[World, dict[Any, Any]] = weakref.WeakKeyDictionary()


def goal_space(world: World, goals: tuple[Goal, ...], max_count: int) -> GoalSpace:
    per_world = _GOAL_SPACES.setdefault(world, {})
    # identity first: hashing 150 goals costs more than the rest of the lookup
    fast = per_world.get((id(goals), max_count))
    if fast is not None and fast[0] is goals:
        hit: GoalSpace = fast[1]
        return hit
    key = (goals, max_count)
    gs: GoalSpace | None = per_world.get(key)
    if gs is None:
        N = goal_matrix(world, goals)
        G, C = N.shape
        uniq, (gi, ci, pair_row) = subgoal_rows(N.tobytes(), G, C)
        kmax = max(int(N.max()), max_count)
        gs = GoalSpace(N, SparseGoals.from_dense(N), SparseGoals.from_dense(uniq), gi, ci, pair_row,
                        np.bincount(world.item_class_idx, minlength=C),
                        CostToGo(world, goals[0].target, kmax, agent=HUMAN))
        if len(per_world) > 32:
            per_world.clear()
        per_world[key] = gs
    per_world[(id(goals), max_count)] = (goals, gs)
    return gs


@lru_cache(maxsize=64)
def subgoal_rows(key: bytes, G: int, C: int) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Distinct human subgoals: every goal minus one of its classes (the robot's part), cached.

    Only these rows enter the action likelihood; the full goals are needed once, for the
    help prior, when the posterior is asked for.
    """
    N = np.frombuffer(key, dtype=np.int64).reshape(G, C)
    gi, ci = np.nonzero(N)
    minus = N[gi].copy()
    minus[np.arange(len(gi)), ci] = 0
    uniq, inv = np.unique(minus, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    for a in (uniq, inv, gi, ci):
        a.setflags(write=False)
    return uniq, (gi, ci, inv)
