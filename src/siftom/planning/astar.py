"""Optimal A* search over world states, with budgets in and counters out.

Failure is a value: :class:`PlanResult` carries a :class:`Status` (solved, unsolvable, node
limit, time limit) rather than ``None``. With ``heuristic=None`` the search is uniform-cost
(Dijkstra), the brute-force reference the tests compare A* against.
"""

from __future__ import annotations

import enum
import heapq
import itertools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from siftom.world.model import HUMAN, Action, Goal, State, World, apply, cost, legal_actions


class Status(enum.Enum):
    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    NODE_LIMIT = "node_limit"
    TIME_LIMIT = "time_limit"


@dataclass(frozen=True)
class PlanResult:
    """Outcome of a search: status, plan, its cost and the work done."""

    status: Status
    plan: tuple[Action, ...] = ()
    cost: float = float("inf")
    nodes_expanded: int = 0
    seconds: float = 0.0
    states: tuple[State, ...] = field(default=(), repr=False)

    @property
    def solved(self) -> bool:
        return self.status is Status.SOLVED


def astar(
    start: State,
    is_goal: Callable[[State], bool],
    successors: Callable[[State], Iterable[tuple[Action, State, float]]],
    heuristic: Callable[[State], float] | None = None,
    max_nodes: int = 200_000,
    max_time: float = 10.0,
) -> PlanResult:
    """A* from ``start``; optimal when ``heuristic`` is admissible (never overestimates)."""
    t0 = time.perf_counter()
    h = heuristic or (lambda _s: 0.0)
    tie = itertools.count()
    g_best: dict[State, float] = {start: 0.0}
    parent: dict[State, tuple[State, Action] | None] = {start: None}
    frontier = [(h(start), next(tie), 0.0, start)]
    expanded = 0
    while frontier:
        _f, _t, g, s = heapq.heappop(frontier)
        if g > g_best.get(s, float("inf")):
            continue
        if is_goal(s):
            plan, states = [], [s]
            node = s
            while parent[node] is not None:
                prev, a = parent[node]  # type: ignore[misc]
                plan.append(a)
                states.append(prev)
                node = prev
            return PlanResult(Status.SOLVED, tuple(reversed(plan)), g, expanded,
                              time.perf_counter() - t0, tuple(reversed(states)))
        expanded += 1
        if expanded > max_nodes:
            return PlanResult(Status.NODE_LIMIT, nodes_expanded=expanded, seconds=time.perf_counter() - t0)
        if expanded % 256 == 0 and time.perf_counter() - t0 > max_time:
            return PlanResult(Status.TIME_LIMIT, nodes_expanded=expanded, seconds=time.perf_counter() - t0)
        for a, s2, c in successors(s):
            g2 = g + c
            if g2 < g_best.get(s2, float("inf")):
                g_best[s2] = g2
                parent[s2] = (s, a)
                heapq.heappush(frontier, (g2 + h(s2), next(tie), g2, s2))
    return PlanResult(Status.UNSOLVABLE, nodes_expanded=expanded, seconds=time.perf_counter() - t0)


def plan_for_goal(
    world: World,
    start: State,
    goal: Goal,
    agent: int = HUMAN,
    use_heuristic: bool = True,
    max_nodes: int = 200_000,
    max_time: float = 10.0,
    prune: bool = True,
) -> PlanResult:
    """Optimal plan for one agent to reach ``goal`` (the other agent stays where it is).

    ``prune`` drops actions that can never be on an optimal plan for a fetch-and-place goal:
    closing a container, and walking to a place that holds no object of a needed class and is
    neither the target nor a place to put down (docs/planning.md argues why this is safe).
    """
    from siftom.planning.costtogo import CostToGo, goal_matrix

    kmax = max([n for _c, n in goal.counts] + [1])
    ctg = CostToGo(world, goal.target, kmax, agent=agent)
    N = goal_matrix(world, [goal])
    needed = {c for c, _n in goal.counts}

    def successors(s: State):
        here = s.agent_at[agent]
        useful = {goal.target, here}
        if prune:
            h = s.held[agent]
            if h >= 0 and world.items[h].cls not in needed:  # somewhere to put it down
                useful.update(i for i, p in enumerate(world.places) if p.kind != "room")
            for i, loc in enumerate(s.item_at):
                if loc >= 0 and world.items[i].cls in needed:
                    useful.add(loc)
        for a in legal_actions(world, s, agent):
            if prune and (a.kind == "close" or (a.kind == "walk" and a.place not in useful)):
                continue
            yield a, apply(s, a), float(cost(world, s, a))

    def heuristic(s: State) -> float:
        return float(ctg.values(ctg.tables(s), N, s.agent_at[agent], s.held[agent], relaxed=True)[0])

    return astar(start, lambda s: goal.satisfied(world, s), successors,
                 heuristic if use_heuristic else None, max_nodes, max_time)
