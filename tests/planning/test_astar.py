"""A*: failure is a value with a status; budgets in, counters out."""

from helpers import three_room_house
from siftom.planning.astar import PlanResult, Status, astar, plan_for_goal
from siftom.world.model import Goal


def test_solved_result_carries_plan_cost_and_counters():
    world, s = three_room_house()
    res = plan_for_goal(world, s, Goal("g", 0, (("fork", 1),)))
    assert res.status is Status.SOLVED and res.solved
    assert res.plan and res.cost > 0 and res.nodes_expanded > 0 and res.seconds >= 0
    assert len(res.states) == len(res.plan) + 1 and res.states[0] == s


def test_a_goal_already_met_costs_nothing():
    world, s = three_room_house()
    res = plan_for_goal(world, s, Goal("g", 1, (("plate", 1),)))
    assert res.solved and res.plan == () and res.cost == 0


def test_impossible_goal_is_unsolvable_not_an_exception():
    world, s = three_room_house()
    res = plan_for_goal(world, s, Goal("three forks", 0, (("fork", 3),)))  # only two exist
    assert res.status is Status.UNSOLVABLE and not res.solved
    assert res.plan == () and res.cost == float("inf") and res.nodes_expanded > 0


def test_node_budget_is_reported_as_a_status():
    world, s = three_room_house()
    res = plan_for_goal(world, s, Goal("g", 0, (("fork", 2), ("cup", 1))), max_nodes=3)
    assert res.status is Status.NODE_LIMIT and not res.solved
    assert res.nodes_expanded == 4 and res.plan == ()


def test_time_budget_is_reported_as_a_status():
    world, s = three_room_house()
    res = plan_for_goal(world, s, Goal("three forks", 0, (("fork", 3),)), use_heuristic=False, prune=False,
                        max_time=0.0)
    assert res.status is Status.TIME_LIMIT and not res.solved and res.nodes_expanded >= 256


def test_astar_on_an_explicit_graph_is_optimal():
    # 0 -> 1 -> 3 costs 2 + 2; 0 -> 2 -> 3 costs 1 + 5; 0 -> 3 directly costs 7
    edges = {0: [(1, 2.0), (2, 1.0), (3, 7.0)], 1: [(3, 2.0)], 2: [(3, 5.0)], 3: []}

    def succ(n):
        return [(f"{n}->{m}", m, c) for m, c in edges[n]]

    res = astar(0, lambda n: n == 3, succ)
    assert isinstance(res, PlanResult)
    assert res.solved and res.cost == 4.0 and res.plan == ("0->1", "1->3")
    assert astar(0, lambda n: n == 9, succ).status is Status.UNSOLVABLE
