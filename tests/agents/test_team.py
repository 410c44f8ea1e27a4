"""Team simulation: L_single, L_team with remedy steps, and speedup = L_single / L_team - 1."""

import pytest

# register both built-in domains whatever was imported first (tests/world/test_domains.py, xfail)
import siftom.world.domains.household  # noqa: F401
import siftom.world.domains.kitchen  # noqa: F401
from helpers import three_room_house
from siftom.agents.team import simulate_scenario, simulate_team
from siftom.errors import CommandParseError
from siftom.planning.astar import plan_for_goal
from siftom.scenarios.base import get_scenario
from siftom.world.commands import RobotCommand
from siftom.world.model import Goal


@pytest.fixture(scope="module")
def cereal():
    return get_scenario("kitchen-cereal-v0")


def test_the_right_command_speeds_the_team_up(cereal):
    res = simulate_scenario(cereal, "fetch(cereal)")
    assert res.speedup > 0
    assert res.useful == 1 and res.wrong == 0 and res.remedy_steps == 0
    assert res.speedup == pytest.approx(res.l_single / res.l_team - 1)
    assert res.l_team == res.prefix + max(res.human_steps, res.robot_steps) + res.remedy_steps


def test_a_wrong_command_costs_remedy_steps_and_helps_less(cereal):
    right = simulate_scenario(cereal, "fetch(cereal)")
    wrong = simulate_scenario(cereal, "fetch(sugar)")
    assert wrong.wrong == 1 and wrong.useful == 0 and wrong.remedy_steps > 0
    assert wrong.speedup < right.speedup
    assert wrong.speedup == pytest.approx(wrong.l_single / wrong.l_team - 1)
    assert wrong.l_single == right.l_single


def test_l_single_is_the_observed_prefix_plus_the_optimal_rest(cereal):
    res = simulate_scenario(cereal, None)
    optimum = plan_for_goal(cereal.world, cereal.now, cereal.goal).cost
    assert res.l_single == res.prefix + optimum == res.l_team and res.speedup == 0
    assert simulate_scenario(cereal, "fetch(cereal)").to_json()["l_single"] == res.l_single


def test_malformed_or_foreign_commands_are_refused(cereal):
    with pytest.raises(CommandParseError, match="valid forms"):
        simulate_scenario(cereal, "fetch cereal")
    with pytest.raises(CommandParseError, match="no object of class"):
        simulate_scenario(cereal, "deliver(fork,3)")


def test_hand_built_team_split():
    """Two forks in the closed drawer, the plate on the counter, the cup in the pantry."""
    world, s = three_room_house()
    goal = Goal("forks and cup", 0, (("fork", 2), ("cup", 1)))
    alone = plan_for_goal(world, s, goal).cost
    res = simulate_team(world, s, goal, RobotCommand("deliver", "fork", 2), prefix_cost=3)
    assert res.l_single == 3 + alone
    assert res.useful == 2 and res.wrong == 0
    human = plan_for_goal(world, s, Goal("cup", 0, (("cup", 1),))).cost
    assert res.human_steps == human and res.l_team == 3 + max(human, res.robot_steps)
    assert res.speedup > 0
    # bringing a plate the goal does not need: the human clears it off the table afterwards
    bad = simulate_team(world, s, goal, RobotCommand("deliver", "plate", 1))
    aside = min(int(world.dist[0, i]) for i in (1, 3))
    assert bad.wrong == 1 and bad.remedy_steps == 2 + 2 * aside
    assert bad.speedup < 0
