"""The free phone loop: the background that tells a fitting key phrase from a forced one."""

from __future__ import annotations

import numpy as np

from siftom.speech.phoneloop import PhoneLoop


def test_the_spoken_sentence_fits_closer_to_free_phones_than_a_wrong_one(cereal_clip, aligner):
    loop = PhoneLoop().score(cereal_clip)
    assert np.isfinite(loop)
    right, wrong = aligner.score(cereal_clip, ["pass me the cereal", "bring me two forks and a knife"]).scores
    frames = len(cereal_clip) / 160
    gap_right, gap_wrong = (loop - right) / frames, (loop - wrong) / frames
    assert gap_right < gap_wrong
    assert gap_wrong - gap_right > 0.2  # nats per 10 ms frame


def test_too_short_audio_has_no_score():
    assert np.isnan(PhoneLoop().score(np.zeros(100, dtype=np.float32)))
