"""Two decodes of one utterance, one N-best: the scene's phrasings and an open vocabulary.

The phrasing LM (``pocketsphinx-vocab``) is the most accurate on requests siftom's grammar
contains, in noise too, but forces other words onto its own, often object names ("after
that i'll need the ham" -> "pass tomato oil need the ham"). The open LM
(``pocketsphinx-open``) hears those words as themselves but, in noise, lets common words
replace object names. ``pocketsphinx-dual`` decodes with both and mixes their N-best lists
as two equally trusted experts:

    log w(h) = log( 1/2 * P_closed(h) + 1/2 * P_open(h) ),  P_k(h) = softmax over list k of its scores

(a hypothesis missing from a list has probability 0 there), keeping the ``nbest`` best. The
scores are natural logs like every engine's; the channel's softmax (``asr_temperature``) then
weighs them. Measurements: docs/speech.md, "Open vocabulary".
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.observation import Hypothesis
from siftom.speech.asr.base import ASREngine, Transcript, get_engine
from siftom.speech.asr.pocketsphinx import PocketsphinxEngine
from siftom.speech.asr.worker import EngineWorker, WorkerError, workers_enabled
from siftom.speech.audio import as_audio

log = logging.getLogger(__name__)


def mix_nbest(lists: Sequence[Sequence[Hypothesis]], nbest: int) -> tuple[Hypothesis, ...]:
    """Equal-weight mixture of N-best lists, each normalised to log-probabilities over its own
    hypotheses; best first, at most ``nbest``, distinct texts (ties keep the earlier list's order)."""
    mixed: dict[str, list[float]] = {}
    used = [lst for lst in lists if lst]
    if not used:
        return ()
    log_half = -math.log(len(used))
    for lst in used:
        scores = np.array([h.score for h in lst], dtype=float)
        m = scores.max()
        z = m + math.log(float(np.exp(scores - m).sum()))
        seen: set[str] = set()
        for h in lst:
            if h.text in seen:
                continue
            seen.add(h.text)
            mixed.setdefault(h.text, []).append(log_half + h.score - z)
    out = [(t, float(np.logaddexp.reduce(v))) for t, v in mixed.items()]
    out.sort(key=lambda kv: -kv[1])  # stable: equal scores keep first-seen order
    return tuple(Hypothesis(t, s) for t, s in out[:nbest])


class DualEngine:
    """``pocketsphinx-vocab`` and ``pocketsphinx-open`` on the same audio, N-best lists mixed.

    From the second call on, the open decode runs in a warm worker process
    (:mod:`siftom.speech.asr.worker`, started at the end of the first call) while this process
    decodes with the phrasing LM, so the wall-clock cost is about the slower of the two decodes,
    not their sum. An engine used once (e.g. for one answer) never starts a process. When the
    worker cannot start or fails (or ``SIFTOM_ASR_WORKERS=0``, or ``parallel=False``) both
    decodes run here, one after the other, with the same result.

    Args:
        vocabulary: the scene's phrasings (as for ``pocketsphinx-vocab``).
        max_seconds: refuse longer audio.
        parallel: decode the open LM in a worker process when possible.
        open_options: keyword arguments for the open engine (the registered ``pocketsphinx-open``).
    """

    name = "pocketsphinx-dual"

    def __init__(self, vocabulary: Sequence[str], max_seconds: float = 120.0, parallel: bool = True,
                 **open_options: Any) -> None:
        """Build the phrasing decoder (the open one is built where it is first needed)."""
        self.max_seconds = max_seconds
        self._vocabulary = list(vocabulary)
        self._open_options = {"max_seconds": max_seconds, **open_options}
        self._parallel = parallel and workers_enabled()
        self._worker: EngineWorker | None = None
        self._lock = threading.Lock()
        self._open: ASREngine | None = None
        self._used_worker = False
        self.closed = PocketsphinxEngine(vocabulary=vocabulary, max_seconds=max_seconds)
        self.unknown_words = self.closed.unknown_words

    @property
    def open(self) -> ASREngine:
        """The open engine in this process (built on first use: the sequential path)."""
        if self._open is None:
            self._open = get_engine("pocketsphinx-open", vocabulary=self._vocabulary, **self._open_options)
        return self._open

    @property
    def parallel(self) -> bool:
        """Whether the next decode can use a worker process."""
        return self._parallel

    def close(self) -> None:
        """End the worker process (decoding continues in-process if used again)."""
        if self._worker is not None:
            self._worker.close()
        self._worker = None
        self._parallel = False

    def _start_worker(self) -> None:
        try:
            self._worker = EngineWorker("pocketsphinx-open", vocabulary=self._vocabulary, **self._open_options)
        except WorkerError as exc:
            self._fail(exc)

    def _fail(self, exc: Exception) -> None:
        if self._worker is not None:
            self._worker.close()
        self._worker = None
        self._parallel = False
        log.warning("pocketsphinx-dual decodes sequentially: %s", exc)

    def _open_async(self, x: np.ndarray, nbest: int) -> Callable[[], Transcript]:
        """Start the open decode; return a function that waits for its Transcript."""
        w = self._worker
        if w is not None and (w.owner != os.getpid() or w.evicted):
            # a process-pool copy of an engine used before the fork (close only this process's
            # copies of the pipes), or closed to make room for another engine's worker
            w.close()
            self._worker = w = None
        if w is not None and self._lock.acquire(blocking=False):  # another thread has it: decode here
            try:
                if not w.usable:
                    raise WorkerError("the worker process ended")
                if not w.is_ready():  # still starting: decode here this time rather than wait
                    self._lock.release()
                    return lambda: self.open.transcribe(x, nbest=nbest)
                w.submit(x, nbest)

                def wait() -> Transcript:
                    try:
                        tr = w.result()
                        self._used_worker = True
                        return tr
                    except WorkerError as exc:
                        self._fail(exc)
                        return self.open.transcribe(x, nbest=nbest)
                    finally:
                        self._lock.release()

                return wait
            except WorkerError as exc:
                self._fail(exc)
            self._lock.release()
        return lambda: self.open.transcribe(x, nbest=nbest)

    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Decode twice (concurrently when a worker runs) and mix the N-best lists; the 1-best
        words come from the list that supplied the mixed 1-best. ``rtf`` is the wall-clock time
        of the whole call over the audio's duration; ``extra["parallel"]`` says whether the open
        decode ran in the worker process."""
        x = as_audio(audio, max_seconds=self.max_seconds)
        t0 = time.perf_counter()
        self._used_worker = False
        wait = self._open_async(x, nbest)
        try:
            a = self.closed.transcribe(x, nbest=nbest)
        finally:
            b = wait()
        hyps = mix_nbest([a.nbest, b.nbest], nbest)
        text = hyps[0].text if hyps else ""
        words = a.words if text == a.text or text != b.text else b.words
        rtf = (time.perf_counter() - t0) / max(a.audio_s, 1e-6)
        if self._parallel and self._worker is None:
            self._start_worker()  # builds while the caller uses this transcript
        return Transcript(text, hyps, words, rtf, self.name, a.audio_s, extra={"parallel": self._used_worker})
