"""Likelihoods are pure: log_prob returns scores and evidence together, and keeps nothing."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from siftom.likelihood.base import Scores, as_scores
from siftom.likelihood.phonetic import PhoneticLikelihood
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand("fetch", c) for c in ("milk", "cereal", "sugar", "coffee", "bowl", "spoon")]
SAID = ["pass me the milk", "pass me the cereal", "get the sugar", "the coffee please", "a bowl", "spoon"]


def test_scores_are_a_frozen_record():
    s = PhoneticLikelihood().log_prob(Instruction.from_text("pass me the milk"), CMDS)
    assert isinstance(s, Scores) and s.log_probs.shape == (len(CMDS),)
    assert not s.log_probs.flags.writeable
    assert np.argmax(s) == 0  # usable where an array is expected
    assert as_scores(np.zeros(3)).evidence == {}


def test_no_attribute_changes_across_calls():
    lik = PhoneticLikelihood()
    lik.log_prob(Instruction.from_text("pass me the milk"), CMDS)
    public = {k: v for k, v in vars(lik).items() if not k.startswith("_")}
    lik.log_prob(Instruction.from_text("the coffee please"), CMDS)
    assert {k: v for k, v in vars(lik).items() if not k.startswith("_")}.keys() == public.keys()
    assert not any(k.startswith("last_") for k in vars(lik))


def test_threads_share_one_likelihood():
    lik = PhoneticLikelihood()
    alone = [lik.log_prob(Instruction.from_text(t), CMDS).log_probs for t in SAID]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(lambda t: lik.log_prob(Instruction.from_text(t), CMDS).log_probs, SAID * 4))
    for k, lp in enumerate(together):
        np.testing.assert_allclose(lp, alone[k % len(SAID)])
