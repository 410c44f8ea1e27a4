"""The act-or-ask rule (siftom.assist.clarify) and the robot's plan (siftom.assist.route)."""

from __future__ import annotations

import pytest

from siftom.assist.clarify import ClarifyPolicy, clarify, describe_command, expected_value_of_asking
from siftom.assist.route import robot_plan
from siftom.errors import ObservationError
from siftom.scenarios.base import get_scenario


def test_flat_posterior_asks_between_the_top_two():
    c = clarify([("fetch(sugar)", 0.35), ("fetch(cereal)", 0.4), ("fetch(oatmeal)", 0.1)])
    assert c.ask and c.command == "fetch(cereal)"
    assert c.question == "Did you mean the cereal or the sugar?"
    assert c.evi == pytest.approx(0.45)


def test_confident_posterior_acts():
    c = clarify([("fetch(cereal)", 0.9), ("fetch(sugar)", 0.06), ("fetch(milk)", 0.04)])
    assert not c.ask and c.question == "" and "confident" in c.reason


def test_asks_only_when_information_is_worth_its_cost():
    probs = [("fetch(a)", 0.5), ("fetch(b)", 0.03), ("fetch(c)", 0.02)] + [(f"fetch(x{i})", 0.01) for i in range(45)]
    assert not clarify(probs, ClarifyPolicy(threshold=0.6, cost=0.1)).ask  # EVI 0.05 <= 0.1
    assert clarify(probs, ClarifyPolicy(threshold=0.6, cost=0.01)).ask


def test_evi_is_second_plus_third():
    assert expected_value_of_asking([0.1, 0.5, 0.3, 0.1]) == pytest.approx(0.4)


def test_counts_are_spoken():
    assert describe_command("deliver(bowl,3)") == "three bowls"
    assert describe_command("fetch(olive_oil)") == "the olive oil"


def test_policy_is_validated():
    with pytest.raises(ObservationError, match="threshold"):
        ClarifyPolicy(threshold=1.5)


def test_robot_plan_reaches_the_target():
    sc = get_scenario("kitchen-cereal-v0")
    plan = robot_plan(sc, sc.now, "fetch(sugar)")
    assert plan.status == "optimal"
    assert plan.route[-1] == sc.to_json()["target"]
    assert plan.actions[-1].startswith("put(robot, sugar")


def test_robot_plan_falls_back_to_greedy_when_the_budget_is_tiny():
    sc = get_scenario("household-table-v0/3")
    plan = robot_plan(sc, sc.now, "deliver(bowl,3)", max_nodes=2)
    assert plan.status == "greedy"
    assert sum(a.startswith("put(robot, bowl") for a in plan.actions) == 3


def test_one_phrase_maker_for_commands():
    from siftom.assist.questions import describe

    assert describe_command("deliver(waterglass,3)") == describe("deliver(waterglass,3)") == "three water glasses"
