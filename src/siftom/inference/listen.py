"""The parts of hearing a recording (``siftom.Observer.hear``) below the observer.

    audio --> voice-activity detection --(no speech)--> posterior from the actions alone
                     | speech
                     v
              cut to the speech --> ASR (N-best + word times, biased to the scene's phrasings)
                     --> Instruction(nbest, samples, words) --> SIFToM posterior

Everything that depends only on the home is built once and cached, as a robot in one home
would: the recogniser per vocabulary, the model per (mode, likelihood), and the action term per
(scene, observed actions) in an ``OnlineInference``. So a call costs the detection, the
recognition and the instruction likelihood only.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from siftom.inference.model import Posterior
from siftom.observation import Instruction
from siftom.speech.asr import DEFAULT_NBEST

NO_SPEECH = "no speech heard"
NO_INSTRUCTION = "no instruction heard"


def with_likelihood(post: Posterior, name: str, why: str) -> Posterior:
    """``post`` with ``evidence['likelihood']`` (the instruction likelihood that ran) and its reason."""
    return dataclasses.replace(post, evidence={**post.evidence, "likelihood": name, "likelihood_reason": why})


def hear(x: np.ndarray, asr: Any, nbest: int = DEFAULT_NBEST) -> tuple[Instruction | None, Any, Any, dict[str, float]]:
    """Detect speech, cut to it and recognise it: (instruction or None, transcript, vad, timings).

    The recording is cut as a stream of it would be (:func:`siftom.speech.segment.cut`: the same
    segmenter, pre- and post-roll), so a recording sent whole and streamed is heard the same."""
    from siftom.speech.segment import cut
    from siftom.speech.vad import detect_speech, trim

    t0 = time.perf_counter()
    vad = detect_speech(x)
    t1 = time.perf_counter()
    timings = {"vad": t1 - t0}
    if not vad.speech:
        return None, None, vad, timings
    y = cut(x)
    if y is None:  # the same detector decided there was speech: cannot happen, but never lose a request
        y = trim(x, vad)
    tr = asr.transcribe(y, nbest=nbest)
    timings["asr"] = time.perf_counter() - t1
    if not tr.text:
        return None, tr, vad, timings
    instruction = dataclasses.replace(tr.to_instruction(samples=y), snr_db=vad.snr_db)
    return instruction, tr, vad, timings
