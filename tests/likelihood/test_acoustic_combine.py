"""How the acoustic likelihood turns alignment scores into log-likelihoods (no audio needed)."""

from __future__ import annotations

import numpy as np

from siftom.likelihood.acoustic import AcousticLikelihood, RawScores
from siftom.speech.acoustic import FAILED_SCORE


def _raw(scores, phonetic=None, keep=None):
    keep = np.arange(len(scores)) if keep is None else np.asarray(keep)
    return RawScores(keep, tuple([(s, 0.0)] for s in scores), "key",
                     None if phonetic is None else np.asarray(phonetic, dtype=float))


def test_a_failed_alignment_is_uninformative_not_fatal():
    """A command whose alignment failed gets the worst real score, not -1e6 / T."""
    lk = AcousticLikelihood(temperature=10.0, with_phonetic=False)
    out = lk.combine(_raw([-300.0, -320.0, FAILED_SCORE]), 3)
    assert np.allclose(out, [-30.0, -32.0, -32.0])


def test_product_adds_the_nbest_phonetic_likelihood():
    """with_phonetic (the default): alignment / T plus the N-best phonetic log-likelihood."""
    lk = AcousticLikelihood(temperature=10.0)
    assert lk.with_phonetic
    out = lk.combine(_raw([-300.0, -310.0], phonetic=[-1.0, -0.5]), 2)
    assert np.allclose(out, [-31.0, -31.5])
    # the N-best breaks an acoustic tie
    tie = lk.combine(_raw([-300.0, -300.0], phonetic=[-2.0, -0.5]), 2)
    assert np.argmax(tie) == 1


def test_product_does_not_count_the_nbest_twice_for_pruned_commands():
    """A pruned command gets the worst aligned score plus its own phonetic term, once."""
    lk = AcousticLikelihood(temperature=10.0)
    out = lk.combine(_raw([-300.0, -310.0], phonetic=[-1.0, -0.5, -6.0], keep=[0, 1]), 3)
    assert np.allclose(out, [-31.0, -31.5, -31.0 - 6.0])
    alone = AcousticLikelihood(temperature=10.0, with_phonetic=False)
    out2 = alone.combine(_raw([-300.0, -310.0], phonetic=[-1.0, -0.5, -6.0], keep=[0, 1]), 3)
    # without the product a pruned command is below the worst aligned one by its N-best deficit
    assert np.allclose(out2, [-30.0, -31.0, -31.0 - 5.0])


def test_temperature_grows_only_when_alignments_fit_worse_than_free_phones():
    """T * exp(kappa * max(gap, 0)): a poor fit (noise) softens the alignment term, a good one
    (gap <= 0) leaves T as calibrated."""
    base = _raw([-300.0, -330.0])
    lk = AcousticLikelihood(temperature=10.0, with_phonetic=False, gap_scale=2.0)
    plain = lk.combine(base, 2)
    good = lk.combine(RawScores(base.keep, base.items, "key", None, gap=-0.4), 2)
    poor = lk.combine(RawScores(base.keep, base.items, "key", None, gap=0.5), 2)
    assert np.allclose(good, plain)
    assert np.isclose(plain[0] - plain[1], 3.0)
    assert np.isclose(poor[0] - poor[1], 3.0 / np.e)
    off = AcousticLikelihood(temperature=10.0, with_phonetic=False, gap_scale=0.0)
    assert np.allclose(off.combine(RawScores(base.keep, base.items, "key", None, gap=0.5), 2), plain)


def test_gap_scale_must_be_non_negative():
    import pytest

    from siftom.errors import SiftomError

    with pytest.raises(SiftomError, match="gap_scale"):
        AcousticLikelihood(gap_scale=-1.0)


def test_whisper_factor_enters_at_its_temperature_and_pruned_commands_get_the_worst_kept():
    """pool="product": log P = alignment / T + phonetic + w / T_w; a pruned command gets the lowest kept w."""
    lk = AcousticLikelihood(temperature=10.0, whisper=False, whisper_temperature=4.0, pool="product")
    base = _raw([-300.0, -300.0], phonetic=[-1.0, -1.0, -1.0], keep=[0, 1])
    no_w = lk.combine(base, 3)
    with_w = lk.combine(RawScores(base.keep, base.items, "key", base.phonetic, whisper=np.array([-8.0, -20.0])), 3)
    assert np.allclose(with_w - no_w, [-2.0, -5.0, -5.0])
    # Whisper breaks a tie the pocketsphinx channels leave
    assert np.argmax(with_w) == 0 and np.isclose(no_w[0], no_w[1])


def test_whisper_options_are_validated():
    import pytest

    from siftom.errors import SiftomError

    with pytest.raises(SiftomError, match="whisper_temperature"):
        AcousticLikelihood(whisper=False, whisper_temperature=0.0)


def test_without_the_whisper_extra_the_alignment_product_is_used(monkeypatch):
    """A user without siftom[whisper] still gets an acoustic likelihood (the alignment product);
    asking for Whisper then says what to install."""
    import pytest

    from siftom.errors import BackendUnavailableError
    from siftom.likelihood import whisper_factor

    monkeypatch.setattr(whisper_factor, "whisper_available", lambda: False)
    lk = AcousticLikelihood()
    assert not lk.uses_whisper and lk.aligns
    with pytest.raises(BackendUnavailableError, match=r"siftom\[whisper\]"):
        AcousticLikelihood(whisper=True)
