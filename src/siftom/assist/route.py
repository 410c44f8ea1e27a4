"""What the robot would do for a command: its plan and the places it walks through.

An optimal plan comes from A* under a small budget (``max_nodes``, ``max_time``); when the
budget runs out the robot falls back to a greedy plan (nearest remaining object, carry it to
the target, repeat), so a caller always gets a route to draw.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from siftom.planning.astar import plan_for_goal
from siftom.world.commands import RobotCommand
from siftom.world.model import HELD, ROBOT, Action, Goal, State, World


@dataclass(frozen=True)
class RobotPlan:
    """The robot's plan for one command.

    Attributes:
        command: the command, e.g. ``deliver(bowl,3)``.
        actions: actions in ``Predicate(agent, object, location)`` form.
        route: place names the robot stands at, starting where it is now.
        cost: the plan's cost (steps).
        status: ``optimal`` (A*), ``greedy`` (budget ran out) or ``nothing-to-do``.
        nodes_expanded: A* work done.
    """

    command: str
    actions: tuple[str, ...]
    route: tuple[str, ...]
    cost: float
    status: str
    nodes_expanded: int

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        return {"command": self.command, "actions": list(self.actions), "route": list(self.route),
                "cost": self.cost, "status": self.status, "nodes_expanded": self.nodes_expanded}


def _route(world: World, start: State, plan: tuple[Action, ...]) -> tuple[str, ...]:
    places = [start.agent_at[ROBOT]]
    for a in plan:
        if a.kind == "walk" and a.place != places[-1]:
            places.append(a.place)
    return tuple(world.places[p].name for p in places)


def _greedy(world: World, now: State, target: int, cls: str, n: int) -> tuple[list[Action], float]:
    here = now.agent_at[ROBOT]
    avail = [i for i, loc in enumerate(now.item_at) if loc not in (HELD, target) and world.items[i].cls == cls]
    plan: list[Action] = []
    cost = 0.0
    opened: set[int] = set()
    for _ in range(min(n, len(avail))):
        item = min(avail, key=lambda i: (int(world.dist[here, now.item_at[i]]), i))
        avail.remove(item)
        src = now.item_at[item]
        if src != here:
            plan.append(Action("walk", ROBOT, place=src))
            cost += float(world.dist[here, src])
        if world.places[src].closable and not now.is_open(src) and src not in opened:
            plan.append(Action("open", ROBOT, place=src))
            opened.add(src)
            cost += 1
        plan += [Action("grab", ROBOT, obj=item, place=src), Action("walk", ROBOT, place=target),
                 Action("put", ROBOT, obj=item, place=target)]
        cost += 2 + float(world.dist[src, target])
        here = target
    return plan, cost


def robot_plan(scenario: Any, state: State, command: str | RobotCommand,
               max_nodes: int = 50_000, max_time: float = 0.5) -> RobotPlan:
    """Plan the robot's part ``command`` from ``state`` in ``scenario`` (A*, greedy fallback)."""
    cmd = scenario.parse_command(command) if isinstance(command, str) else command
    world: World = scenario.world
    target = scenario.target
    have = world.count_at(state, target, cmd.obj_class)
    avail = sum(1 for i, loc in enumerate(state.item_at)
                if loc not in (HELD, target) and world.items[i].cls == cmd.obj_class)
    n = min(cmd.count, avail)
    if n == 0:
        here = world.places[state.agent_at[ROBOT]].name
        return RobotPlan(str(cmd), (), (here,), 0.0, "nothing-to-do", 0)
    goal = Goal("robot", target, ((cmd.obj_class, have + n),))
    res = plan_for_goal(world, state, goal, agent=ROBOT, max_nodes=max_nodes, max_time=max_time)
    if res.solved:
        plan, cost, status = tuple(res.plan), float(res.cost), "optimal"
    else:
        greedy, cost = _greedy(world, state, target, cmd.obj_class, n)
        plan, status = tuple(greedy), "greedy"
    return RobotPlan(str(cmd), tuple(world.format_action(a) for a in plan), _route(world, state, plan),
                     cost, status, res.nodes_expanded)
