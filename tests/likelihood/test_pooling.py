"""How the acoustic likelihood's experts meet (likelihood/pooling.py; no audio needed)."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import SiftomError
from siftom.likelihood.acoustic import AcousticLikelihood, RawScores
from siftom.likelihood.pooling import pool_experts, transcript_confidence, whisper_slot_factor
from siftom.logspace import logsumexp
from siftom.world.commands import RobotCommand


def _softmax(x: np.ndarray) -> np.ndarray:
    return np.exp(x - logsumexp(x))


def test_product_adds_the_experts_and_a_missing_one_changes_nothing() -> None:
    p, w = np.array([-1.0, -3.0]), np.array([-2.0, -2.5])
    assert np.allclose(pool_experts(p, w, "product"), p + w)
    for pool in ("product", "mixture", "tempered"):
        assert np.allclose(pool_experts(p, 0.0, pool), p)  # no Whisper factor: the N-best alone
        assert np.allclose(pool_experts(None, w, pool), w)


def test_mixture_is_the_mean_of_the_normalised_experts() -> None:
    p, w = np.array([0.0, -12.0, -12.0]), np.array([-6.0, 0.0, -9.0])
    out = np.asarray(pool_experts(p, w, "mixture"))
    assert np.allclose(np.exp(out), 0.5 * _softmax(p) + 0.5 * _softmax(w))
    # the experts disagree: no command is sure (the product gives the N-best's choice 0.99)
    assert _softmax(out).max() < 0.51 and _softmax(p + w).max() > 0.99
    # they agree: the pool is as sure as they are
    assert _softmax(np.asarray(pool_experts(p, p, "mixture"))).max() == pytest.approx(_softmax(p).max())


def test_tempered_product_flattens_as_the_experts_disagree() -> None:
    p = np.array([0.0, -6.0])
    assert np.allclose(pool_experts(p, p, "tempered"), 2 * p)  # agreement: the product as it is
    flat = np.asarray(pool_experts(p, p[::-1].copy(), "tempered"))
    assert np.isclose(flat[0], flat[1])  # opposite experts, the same margin: flat
    some = np.asarray(pool_experts(p, np.array([-1.0, 0.0]), "tempered"))
    assert 0 < some[0] - some[1] < (p + np.array([-1.0, 0.0]))[0] - (p + np.array([-1.0, 0.0]))[1]
    with pytest.raises(ValueError, match="pool"):
        pool_experts(p, p, "sum")


def test_acoustic_likelihood_pools_the_nbest_and_whisper_as_set() -> None:
    raw = RawScores(np.array([0, 1]), (), "whisper-key", np.array([0.0, -8.0, -9.0]),
                    whisper=np.array([-30.0, -3.0]))
    product = AcousticLikelihood(whisper=False, align=True).combine(raw, 3)  # the default pool
    mixture = AcousticLikelihood(whisper=False, align=True, pool="mixture").combine(raw, 3)
    w = np.array([-10.0, -1.0, -10.0])  # / T_w = 3; the pruned third gets the worst kept w
    assert np.allclose(product, raw.phonetic + w)
    assert np.allclose(mixture, pool_experts(raw.phonetic, w, "mixture"))
    with pytest.raises(SiftomError, match="pool"):
        AcousticLikelihood(whisper=False, pool="vote")


def test_transcript_confidence_is_the_geometric_mean_token_probability() -> None:
    assert transcript_confidence(np.log(0.25)) == pytest.approx(0.25)
    assert transcript_confidence(None) == 0.0 and transcript_confidence(float("-inf")) == 0.0
    assert transcript_confidence(0.5) == 1.0


def test_an_unsure_transcript_moves_the_slot_channel_little() -> None:
    cmds = [RobotCommand("fetch", "milk"), RobotCommand("fetch", "honey")]
    full = whisper_slot_factor("pass me the honey", None, cmds, None, None, weighted=False)
    assert full[1] - full[0] > 5  # read at full weight, the transcript's object wins by many nats
    sure = whisper_slot_factor("pass me the honey", np.log(0.9), cmds, None, None)
    unsure = whisper_slot_factor("pass me the honey", np.log(0.2), cmds, None, None)
    assert sure[1] - sure[0] == pytest.approx(np.log(1 / (0.9 * np.exp(full[0] - full[1]) + 0.1)), abs=1e-6)
    assert 0 < unsure[1] - unsure[0] < np.log(1 / 0.8) + 1e-9 < sure[1] - sure[0]
    assert np.allclose(whisper_slot_factor("pass me the honey", None, cmds, None, None), 0.0)  # no confidence


def test_the_default_pool_keeps_a_count_both_experts_heard() -> None:
    """The product is the default: an N-best sure of a count is not flattened by a Whisper factor
    that barely separates the counts (the mixture halves it)."""
    from siftom.likelihood.pooling import DEFAULT_POOL

    assert DEFAULT_POOL == "product"
    nbest = np.array([0.0, -9.0, -9.0])  # "i need four teaspoons": four, heard without a word wrong
    whisper = np.array([-1.0, -0.8, -1.1])  # Whisper's teacher-forced scores: the counts barely differ
    product = np.asarray(pool_experts(nbest, whisper, DEFAULT_POOL))
    mixture = np.asarray(pool_experts(nbest, whisper, "mixture"))
    share = lambda x: float(np.exp(x[0] - np.logaddexp.reduce(x)))  # noqa: E731
    assert share(product) > 0.99 > 0.7 > share(mixture)  # the mixture: about 2/3
