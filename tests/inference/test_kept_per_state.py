"""What the online inference keeps per state (the candidates, the prior and action terms) never
outlives the state: a posterior after more actions, or of a view under another model, is the one
a fresh inference gives."""

import copy

import numpy as np

import siftom.world.domains.household  # noqa: F401
import siftom.world.domains.kitchen  # noqa: F401
from siftom.inference.model import ModelConfig, SIFToM
from siftom.likelihood.base import Instruction
from siftom.scenarios.base import get_scenario

HEARD = Instruction.from_text("could you get the bowls")


def _fresh(sc, n):
    on = SIFToM().online(sc.world, sc.start, sc.goals, sc.verb)
    for a in sc.actions[:n]:
        on.observe(a)
    return on


def _same(a, b):
    assert a.commands == b.commands and a.goals == b.goals and a.hypotheses == b.hypotheses
    np.testing.assert_array_equal(a.joint.log_joint, b.joint.log_joint)


def test_a_posterior_after_more_actions_is_a_fresh_one():
    sc = get_scenario("household-table-v0/0")
    on = _fresh(sc, 0)
    for n, a in enumerate(sc.actions[:4]):
        first = on.posterior(HEARD)
        _same(on.posterior(HEARD), first)  # kept: the same posterior again
        _same(first, _fresh(sc, n).posterior(HEARD))
        on.observe(a)
    _same(on.posterior(HEARD), _fresh(sc, 4).posterior(HEARD))


def test_a_view_under_another_model_shares_what_is_kept_and_answers_as_that_model():
    """The observer scores one online inference under several models through shallow copies."""
    sc = get_scenario("household-table-v0/0")
    on = _fresh(sc, 3)
    on.posterior(HEARD)  # fills what is kept
    for cfg in (ModelConfig(mode="action-only"), ModelConfig(off_plan=0.2), ModelConfig(mode="speech-only")):
        view = copy.copy(on)
        view.model = SIFToM(cfg)
        fresh = SIFToM(cfg).online(sc.world, sc.start, sc.goals, sc.verb)
        for a in sc.actions[:3]:
            fresh.observe(a)
        _same(view.posterior(HEARD), fresh.posterior(HEARD))


def test_the_kept_arrays_are_read_only():
    on = _fresh(get_scenario("kitchen-cereal-v0"), 2)
    goal_idx, cmd_of, rows, unk, cmds = on.candidates()
    assert not goal_idx.flags.writeable and not cmd_of.flags.writeable
    cmds.append(cmds[0])  # the caller's own list
    assert len(on.candidates()[4]) == len(cmds) - 1
