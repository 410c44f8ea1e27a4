"""Team simulation for the evaluator: agents/team.py with shared, deterministic planning calls.

``simulate_team`` plans the human-alone problem (``L_single``) again for every command, and the
human's part under a wrong-class command is the same problem again with the robot's objects
removed. In the household domain one such A* call takes 2-35 s (3k-70k nodes), so scoring
five models on 20 stimuli per scenario would spend most of an evaluation re-solving them.

:func:`shared_solves` wraps team.py's planning call, for the duration of a ``with`` block, with
two changes that keep its results and make them cheaper and reproducible:

* a cache keyed on the *relevant* state: the agents, what they hold, the open containers and
  the positions of objects of the goal's classes. Objects of other classes never lie on an
  optimal plan for a fetch-and-place goal (the planner prunes them: planning/astar.py), so
  their positions do not change the optimal cost, and removing them (a wrong-class robot
  command) does not either;
* a node budget instead of a wall-clock limit (``MAX_NODES``; team.py uses 20 s), so the answer
  does not depend on how busy the machine is.

Only the cost and the plan's grabbed objects are used by team.py; both are invariant under the
cache key for the agent's own goal.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from siftom.errors import SiftomError

MAX_NODES = 1_500_000
_CACHE: dict[tuple[Any, ...], tuple[float, tuple]] = {}


def _key(world: Any, s: Any, goal: Any, agent: int) -> tuple[Any, ...]:
    needed = {c for c, _ in goal.counts}
    rel = tuple(loc for i, loc in enumerate(s.item_at) if world.items[i].cls in needed)
    return (id(world), s.agent_at, s.held, rel, s.open_mask, goal.target, goal.counts, agent)


def _solve(world: Any, s: Any, goal: Any, agent: int) -> tuple[float, tuple]:
    from siftom.planning.astar import plan_for_goal

    if not goal.counts or goal.satisfied(world, s):
        return 0.0, ()
    key = _key(world, s, goal, agent)
    hit = _CACHE.get(key)
    if hit is None:
        res = plan_for_goal(world, s, goal, agent=agent, max_nodes=MAX_NODES, max_time=float("inf"))
        if not res.solved:
            raise SiftomError(f"no plan for {goal.describe()} within {MAX_NODES} nodes ({res.status.value})")
        hit = _CACHE[key] = (res.cost, res.plan)
    return hit


@contextlib.contextmanager
def shared_solves() -> Iterator[None]:
    """Within the block, team.py's planning calls are cached and node-limited (module doc)."""
    from siftom.agents import team

    original = getattr(team, "_solve", None)
    if original is None:  # team.py changed shape: fall back to its own planning
        yield
        return
    team._solve = _solve  # type: ignore[attr-defined]
    try:
        yield
    finally:
        team._solve = original  # type: ignore[attr-defined]


def clear_cache() -> None:
    """Forget cached plans (worlds are keyed by identity, so call this when they are freed)."""
    _CACHE.clear()
