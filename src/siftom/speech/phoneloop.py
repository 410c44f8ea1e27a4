"""A free phone loop over a span of audio: the background score for keyword verification.

pocketsphinx's all-phone decoder (the shipped phone bigram LM, ``en-us-phone.lm.bin``) finds
the best phone sequence for the audio with no word constraint. Its path score, in nats, is what
*any* speech over those frames scores; a forced alignment of some words minus this score is a
log-likelihood ratio that says how much better the words explain the frames than speech in
general (docs/likelihoods.md, "Acoustic likelihood").
"""

from __future__ import annotations

import numpy as np

from siftom.concurrency import guarded
from siftom.speech.asr.pocketsphinx import _ps, model_path, path_score_nats
from siftom.speech.audio import to_pcm16

FAILED = float("nan")


class PhoneLoop:
    """Reusable all-phone decoder."""

    def __init__(self) -> None:
        """Load the acoustic model with the phone bigram LM (about 0.3 s)."""
        ps = _ps()
        self._decoder = ps.Decoder(allphone=model_path("en-us/en-us-phone.lm.bin"), lm=None, lw=2.0,
                                   beam=1e-20, pbeam=1e-20, bestpath=False, loglevel="FATAL")
        self._logmath = self._decoder.get_logmath()

    @guarded  # a native decoder decodes one utterance at a time
    def score(self, x: np.ndarray) -> float:
        """Best phone-loop path score of 16 kHz samples, in nats (NaN when decoding fails)."""
        if len(x) < 800:
            return FAILED
        dec = self._decoder
        try:
            dec.reinit_feat()
            dec.start_utt()
            dec.process_raw(to_pcm16(x), full_utt=True)
            dec.end_utt()
        except RuntimeError:
            return FAILED
        hyp = dec.hyp()
        return FAILED if hyp is None else path_score_nats(self._logmath, hyp.score)
