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
from collections.abc import Callable, Hashable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from siftom.errors import unknown_name
from siftom.world.model import HUMAN, Action, Goal, State, World, apply, cost, legal_actions

_L = TypeVar("_L")  # what labels a step of the plan (an action, or a macro of several)
_S = TypeVar("_S", bound=Hashable)  # a search state


class Status(enum.Enum):
    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    NODE_LIMIT = "node_limit"
    TIME_LIMIT = "time_limit"


@dataclass(frozen=True)
class PlanResult(Generic[_L, _S]):
    """Outcome of a search: status, plan, its cost and the work done."""

    status: Status
    plan: tuple[_L, ...] = ()
    cost: float = float("inf")
    nodes_expanded: int = 0
    seconds: float = 0.0
    states: tuple[_S, ...] = field(default=(), repr=False)

    @property
    def solved(self) -> bool:
        return self.status is Status.SOLVED


def astar(
    start: _S,
    is_goal: Callable[[_S], bool],
    successors: Callable[[_S], Iterable[tuple[_L, _S, float]]],
    heuristic: Callable[[_S], float] | None = None,
    max_nodes: int = 200_000,
    max_time: float = 10.0,
) -> PlanResult[_L, _S]:
    """A* from ``start``; optimal when ``heuristic`` is admissible (never overestimates)."""
    t0 = time.perf_counter()
    h = heuristic or (lambda _s: 0.0)
    tie = itertools.count()
    g_best: dict[_S, float] = {start: 0.0}
    parent: dict[_S, tuple[_S, _L] | None] = {start: None}
    # ties on f are broken towards deeper nodes (larger g): fetch orders of equal cost are
    # interchangeable, and without this A* expands every one of them
    frontier = [(h(start), 0.0, next(tie), 0.0, start)]
    expanded = 0
    while frontier:
        _f, _ng, _t, g, s = heapq.heappop(frontier)
        if g > g_best.get(s, float("inf")):
            continue
        if is_goal(s):
            plan: list[_L] = []
            states = [s]
            node = s
            while (link := parent[node]) is not None:
                prev, a = link
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
                heapq.heappush(frontier, (g2 + h(s2), -g2, next(tie), g2, s2))
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
    heuristic: str = "admissible",
) -> PlanResult[Action, State]:
    """Optimal plan for one agent to reach ``goal`` (the other agent stays where it is).

    ``heuristic="admissible"`` (default) guarantees an optimal plan. ``"fast"`` uses the full
    fast cost-to-go, which can overestimate when several classes share containers
    (docs/planning.md, "Exactness"): the plan may then be a step above optimal, and A* expands
    far fewer nodes on large goals.

    ``prune`` drops actions that can never be on an optimal plan for a fetch-and-place goal
    (docs/planning.md argues why each is safe): closing a container; grabbing an object of a
    class the goal does not need, or one already on the target; opening a container with no
    needed object (unless a spare object needs a place); walking to a place that holds no
    needed object and is not the target (unless a spare object needs a place); and a walk not
    followed by an action at its destination (walks are expanded as walk+action macros).
    """
    from siftom.planning.costtogo import CostToGo, goal_matrix

    kmax = max([n for _c, n in goal.counts] + [1])
    ctg = CostToGo(world, goal.target, kmax, agent=agent)
    N = goal_matrix(world, [goal])
    successors = _successors(world, goal, agent, prune)
    if heuristic not in ("admissible", "fast"):
        raise unknown_name("heuristic", heuristic, ("admissible", "fast"))
    fast = heuristic == "fast"
    opens_lower_bound = _opens_lower_bound(world, goal, agent)

    def h(s: State) -> float:
        if fast:
            return float(ctg.values(ctg.tables(s), N, s.agent_at[agent], s.held[agent])[0])
        v = float(ctg.values(ctg.tables(s), N, s.agent_at[agent], s.held[agent], relaxed=True)[0])
        return v + opens_lower_bound(s)

    res = astar(start, lambda s: goal.satisfied(world, s), successors,
                h if use_heuristic else None, max_nodes, max_time)
    if not res.solved:  # no plan: the same result, its (empty) plan typed as single actions
        return PlanResult(res.status, (), res.cost, res.nodes_expanded, res.seconds)
    plan = tuple(a for macro in res.plan for a in macro)
    states = [start]
    for a in plan:
        states.append(apply(states[-1], a))
    return PlanResult(res.status, plan, res.cost, res.nodes_expanded, res.seconds, tuple(states))


def _successors(world: World, goal: Goal, agent: int,
                prune: bool) -> Callable[[State], Iterator[tuple[tuple[Action, ...], State, float]]]:
    """The successor function of :func:`plan_for_goal`: single actions, or (``prune``) the
    actions worth considering, walks expanded as walk+action macros (its docstring)."""
    needed = {c for c, _n in goal.counts}

    def acts_here(s: State) -> Iterator[Action]:
        """Non-walk actions worth considering where the agent stands (pruned, see plan_for_goal)."""
        h = s.held[agent]
        holding_spare = h >= 0 and world.items[h].cls not in needed
        for a in legal_actions(world, s, agent):
            if a.kind == "walk":
                continue
            if prune:
                if a.kind == "close":
                    continue
                if a.kind == "grab" and (world.items[a.obj].cls not in needed or a.place == goal.target):
                    continue
                if a.kind == "open" and not holding_spare and not any(
                        loc == a.place and world.items[i].cls in needed for i, loc in enumerate(s.item_at)):
                    continue
            yield a

    def successors(s: State) -> Iterator[tuple[tuple[Action, ...], State, float]]:
        if not prune:
            for a in legal_actions(world, s, agent):
                yield (a,), apply(s, a), float(cost(world, s, a))
            return
        here = s.agent_at[agent]
        for a in acts_here(s):
            yield (a,), apply(s, a), 1.0
        useful = {goal.target}
        h = s.held[agent]
        if h >= 0 and world.items[h].cls not in needed:  # somewhere to put it down
            useful.update(i for i, p in enumerate(world.places) if p.kind != "room")
        for i, loc in enumerate(s.item_at):
            if loc >= 0 and world.items[i].cls in needed:
                useful.add(loc)
        useful.discard(here)
        # a walk is always followed by an action at its destination (two walks in a row are
        # never shorter than one, by the triangle inequality), so walks come as macros
        for p in useful:
            w = Action("walk", agent, place=p)
            s1 = apply(s, w)
            d = float(cost(world, s, w))
            for a in acts_here(s1):
                yield (w, a), apply(s1, a), d + 1.0

    return successors


def _opens_lower_bound(world: World, goal: Goal, agent: int) -> Callable[[State], int]:
    counts = dict(goal.counts)
    closable = [p.closable for p in world.places]

    def opens_lower_bound(s: State) -> int:
        """Closed containers that must still be opened: admissible (see docs/planning.md).

        A class whose deficit cannot be met from open places and whose remaining objects lie in
        a single closed container forces that container; if some deficit is still unmet after
        opening the forced ones, at least one more must be opened.
        """
        short: dict[str, set[int]] = {}
        for c, n in counts.items():
            have = sum(1 for i, loc in enumerate(s.item_at) if loc == goal.target and world.items[i].cls == c)
            if s.held[agent] >= 0 and world.items[s.held[agent]].cls == c:
                have += 1
            free = sum(1 for i, loc in enumerate(s.item_at)
                       if loc >= 0 and loc != goal.target and world.items[i].cls == c
                       and not (closable[loc] and not s.is_open(loc)))
            if have + free < n:
                short[c] = {loc for i, loc in enumerate(s.item_at)
                            if loc >= 0 and world.items[i].cls == c and closable[loc] and not s.is_open(loc)}
        if not short:
            return 0
        forced = {next(iter(v)) for v in short.values() if len(v) == 1}
        rest = any(not (v & forced) for v in short.values())
        return len(forced) + (1 if rest else 0)

    return opens_lower_bound
