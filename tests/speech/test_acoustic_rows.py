"""The evaluator's acoustic rows hear a clip exactly as the N-best rows do (only the likelihood differs)."""

from __future__ import annotations

import numpy as np

from siftom.bench.acoustic_models import heard
from siftom.speech.audio import write_wav


def test_acoustic_rows_recognise_the_whole_clip_like_the_nbest_rows(cereal_clip, vocab_engine, tmp_path):
    from siftom.speech.noise import get_noise, mix_at_snr

    x = mix_at_snr(cereal_clip, get_noise("babble"), 5.0, 2)
    path = write_wav(tmp_path / "noisy.wav", x)
    instruction, vad = heard(path, vocab_engine, 5)
    plain = vocab_engine.transcribe(path, nbest=5)  # what the evaluator gives siftom / speech-only
    assert instruction is not None
    assert [h.text for h in instruction.nbest] == [h.text for h in plain.nbest if h.text]
    assert len(instruction.samples) == len(x)  # not trimmed
    assert instruction.words and vad.snr_db is not None and np.isfinite(vad.snr_db)
