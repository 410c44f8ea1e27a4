"""Team simulation: L_single, L_team with remedy steps, and speedup (paper, Performance Metrics).

Definitions (docs/team-simulation.md gives the reasons):

* ``L_single`` = cost of the human's observed actions + the optimal cost (A*) for the human
  alone to reach the goal from the state when they spoke.
* The robot executes its command from that state: an optimal plan (A*) that puts
  ``count`` objects of the class on the target; the objects it will take are reserved, so
  the human plans around them. Its duration is ``R``.
* The human, in parallel, reaches the goal minus what the robot brings that is useful
  (at most the number of that class the goal still needs): duration ``H`` (A*).
* Remedy: every object the robot brings that the goal does not need (wrong class, or more
  than needed) must be cleared off the target by the human: grab it, walk to the nearest
  other surface, put it there, walk back: ``2 + 2 * d(target, nearest surface)`` each, after
  the robot is done.
* ``L_team`` = observed cost + max(H, R) + remedy; ``speedup = L_single / L_team - 1``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from siftom.errors import SiftomError
from siftom.planning.astar import plan_for_goal
from siftom.world.commands import RobotCommand
from siftom.world.model import HELD, HUMAN, NOTHING, ROBOT, Action, Goal, State, World


@dataclass(frozen=True)
class TeamResult:
    """Outcome of simulating one robot command."""

    command: str
    l_single: float
    l_team: float
    speedup: float
    prefix: float
    human_steps: float
    robot_steps: float
    remedy_steps: float
    useful: int
    wrong: int

    def to_json(self) -> dict[str, Any]:
        return dict(self.__dict__)


def _reserve(state: State, items: set[int]) -> State:
    """The state with ``items`` removed from play (they are the robot's)."""
    item_at = tuple(HELD if i in items else loc for i, loc in enumerate(state.item_at))
    return State(state.agent_at, state.held, item_at, state.open_mask)


MAX_NODES = 500_000
# (world id, agent place, held, needed objects' places, containers, target, counts, agent)
_PlanKey = tuple[int, int, int, tuple[int, ...], int, int, tuple[tuple[str, int], ...], int]
_PLANS: dict[_PlanKey, tuple[float, tuple[Action, ...], World]] = {}


def _solve(world: World, s: State, goal: Goal, agent: int) -> tuple[float, tuple[Action, ...]]:
    """Plan cost and plan, cached on the part of the state that matters to the goal.

    A* uses the fast cost-to-go as heuristic (exact on the built-in scenarios' states; where
    it overestimates, a plan can be a step above optimal; docs/planning.md) and a node budget
    rather than a clock, so results do not depend on how busy the machine is. Objects of
    classes the goal does not need never lie on such a plan, so their positions are not part
    of the cache key.
    """
    if not goal.counts or goal.satisfied(world, s):
        return 0.0, ()
    needed = {c for c, _ in goal.counts}
    rel = tuple(loc for i, loc in enumerate(s.item_at) if world.items[i].cls in needed)
    key = (id(world), s.agent_at[agent], s.held[agent], rel, s.open_mask, goal.target, goal.counts, agent)
    hit = _PLANS.get(key)
    if hit is not None and hit[2] is world:
        return hit[0], hit[1]
    res = plan_for_goal(world, s, goal, agent=agent, max_nodes=MAX_NODES, max_time=float("inf"), heuristic="fast")
    if not res.solved:
        raise SiftomError(f"no plan for {goal.describe()} ({res.status.value}); the scenario may be unsolvable")
    if len(_PLANS) > 100_000:
        _PLANS.clear()
    _PLANS[key] = (res.cost, res.plan, world)
    return res.cost, res.plan


def simulate_team(world: World, now: State, goal: Goal, command: RobotCommand | None,
                  prefix_cost: float = 0.0) -> TeamResult:
    """Simulate the human alone and the human + robot team from ``now`` (see module doc)."""
    single, _ = _solve(world, now, goal, HUMAN)
    l_single = prefix_cost + single
    if command is None:
        return TeamResult("none", l_single, l_single, 0.0, prefix_cost, single, 0.0, 0.0, 0, 0)
    T = goal.target
    cls, n = command.obj_class, command.count
    have = world.count_at(now, T, cls)
    avail = [i for i, loc in enumerate(now.item_at) if loc not in (HELD, T) and world.items[i].cls == cls]
    n = min(n, len(avail))
    robot_goal = Goal("robot", T, ((cls, have + n),)) if n else Goal("robot", T, ())
    # the robot works alone on a copy where the human's held object stays with the human
    r_steps, r_plan = _solve(world, now, robot_goal, ROBOT)
    taken = {a.obj for a in r_plan if a.kind == "grab"}
    need_c = max(0, goal.count_map.get(cls, 0) - have - (
        1 if now.held[HUMAN] != NOTHING and world.items[now.held[HUMAN]].cls == cls else 0))
    useful = min(n, need_c)
    wrong = n - useful
    human_goal = goal.minus(cls, useful) if useful else goal
    h_steps, _ = _solve(world, _reserve(now, taken), human_goal, HUMAN)
    surfaces = [i for i, p in enumerate(world.places) if p.kind != "room" and i != T and not p.closable]
    d_aside = min((int(world.dist[T, i]) for i in surfaces), default=1)
    remedy = wrong * (2 + 2 * d_aside)
    l_team = prefix_cost + max(h_steps, r_steps) + remedy
    return TeamResult(str(command), l_single, l_team, l_single / l_team - 1.0 if l_team > 0 else 0.0,
                      prefix_cost, h_steps, r_steps, float(remedy), useful, wrong)


def simulate_scenario(scenario: Any, command: RobotCommand | str | None) -> TeamResult:
    """Team simulation for a registered scenario, from the moment the human spoke."""
    from siftom.world.model import cost as action_cost

    cmd: RobotCommand | None = scenario.parse_command(command) if isinstance(command, str) else command
    states = scenario.states()
    prefix = sum(action_cost(scenario.world, s, a) for s, a in zip(states, scenario.actions, strict=False))
    return simulate_team(scenario.world, states[-1], scenario.goal, cmd, prefix)
