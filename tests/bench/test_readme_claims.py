"""README claims that come from slow benchmark commands, re-checked (make test-slow)."""

import shutil

import pytest

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(shutil.which("flite") is None or shutil.which("espeak-ng") is None,
                                 reason="needs flite and espeak-ng (make sysdeps)")]


def test_acoustic_scorer_ranks_the_true_sentence_first_on_clean_speech():
    # README, Speech: `siftom bench acoustic` -> 99.4 % of 180 clean utterances, N-best 98.3 %
    from siftom.bench.speech import run_acoustic_bench

    res = run_acoustic_bench()
    assert res.utterances == 180
    assert res.accuracy >= 0.99
    assert res.phonetic_accuracy >= 0.97
