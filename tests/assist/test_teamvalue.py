"""With the truth known, the decision's utility predicts exactly what the team simulation scores."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import phonetic_model
from siftom.agents.team import simulate_scenario
from siftom.assist.decide import Situation, decide
from siftom.assist.teamvalue import NONE, team_values
from siftom.inference.model import JointPosterior, Observation
from siftom.likelihood.base import Instruction
from siftom.scenarios.base import get_scenario


def _point_mass(sc):
    """The posterior's hypotheses reduced to one row: the scenario's true goal."""
    post = phonetic_model().infer(Observation.from_scenario(sc, Instruction.from_text("bring it")))
    j = post.joint
    gi = [g.name for g in j.goals].index(sc.goal.name)
    return post, JointPosterior(j.goals, j.commands, np.array([gi]), np.array([0]), np.array([0.0]), j.state)


# kitchen scenarios and household scenarios whose robot, starting away from the target, takes a
# nearby object first (the case the utility once got wrong by up to 17 steps), and household
# scenarios where the cost-to-go was one step off A* before session 5 (a first object from a
# container its round trips would not open; /1: every command, through L_single)
@pytest.mark.parametrize("sid", ["kitchen-v0/0", "kitchen-v0/4", "kitchen-v0/8", "household-table-v0/0",
                                 "household-table-v0/16", "household-table-v0/19", "household-table-v0/20",
                                 "household-table-v0/1", "household-table-v0/4", "household-table-v0/15",
                                 "household-table-v0/23"])
def test_point_mass_utility_predicts_the_simulated_team_time(sid):
    sc = get_scenario(sid)
    _post, pm = _point_mass(sc)
    where = Situation.from_scenario(sc)
    tv = team_values(pm, sc.world, sc.target, where.state, where.prefix)
    sp = tv.speedup()
    for a, cmd in enumerate(tv.actions[:-1]):
        r = simulate_scenario(sc, cmd)
        assert where.prefix + tv.single[0] == r.l_single, cmd
        assert where.prefix + tv.single[0] - tv.benefit[0, a] == r.l_team, cmd
        assert sp[0, a] == pytest.approx(r.speedup), cmd
    assert tv.actions[-1] == NONE and tv.benefit[0, -1] == 0.0 and sp[0, -1] == 0.0


def test_with_the_truth_known_expected_benefit_picks_the_fastest_team():
    # risk-neutral or loss-averse, in steps or in speedup: with a point mass on the truth the
    # rule's choice is the simulation's best action
    sc = get_scenario("household-table-v0/19")
    post, pm = _point_mass(sc)
    from dataclasses import replace

    certain = replace(post, joint=pm, evidence={})  # the point mass stands for a heard instruction
    where = Situation.from_scenario(sc)
    best = max(simulate_scenario(sc, c).speedup for c in team_values(pm, sc.world, sc.target).actions[:-1])
    for unit in ("steps", "speedup"):
        for lam in (0.0, 3.0):
            d = decide(certain, where, "expected-benefit", loss_aversion=lam, utility=unit, scope="any")
            got = 0.0 if d.action == NONE else simulate_scenario(sc, d.action).speedup
            assert got == pytest.approx(max(best, 0.0))


def test_steps_already_spent_count_in_every_outcome():
    # after a question the team is 2 steps behind whatever the robot does; a loss-averse robot
    # then compares u(b - 2) across actions, doing nothing included (-2 is a loss)
    sc = get_scenario("household-table-v0/3")
    post = phonetic_model().infer(Observation.from_scenario(sc, Instruction.from_text("get the spoons")))
    where = Situation.from_scenario(sc)
    tv = team_values(post.joint, sc.world, sc.target, where.state)
    for spent in (0.0, 2.0, 6.0):
        b = tv.benefit - spent
        u = b - 3.0 * np.maximum(0.0, -b)
        eu = tv.prob @ u
        want = tv.actions[-1] if eu[-1] >= eu.max() - 1e-9 else tv.actions[int(np.argmax(eu))]
        assert decide(post, where, "expected-benefit", loss_aversion=3.0, spent=spent, scope="any").action == want
    # doing nothing is a loss once steps were spent: its utility falls by (1 + aversion) per step
    none_u = [float(tv.prob @ (tv.benefit[:, -1] - x - 3.0 * np.maximum(0.0, -(tv.benefit[:, -1] - x))))
              for x in (0.0, 2.0)]
    assert none_u[1] == pytest.approx(none_u[0] - 8.0)


def test_unknown_utility_is_refused_with_the_choices():
    from siftom.errors import ObservationError

    sc = get_scenario("kitchen-v0/0")
    post, _pm = _point_mass(sc)
    with pytest.raises(ObservationError, match="steps, speedup"):
        decide(post, Situation.from_scenario(sc), "expected-benefit", utility="minutes")
