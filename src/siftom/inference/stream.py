"""Listen to a stream: utterances cut by the voice-activity detector, each recognised and answered.

One class, :class:`StreamListener`, serves every live input (the WebSocket endpoint, ``siftom
listen --mic/--wav`` and the ROS bridge), so they cut utterances the same way::

    chunks --> UtteranceSegmenter --> speech_started ... speech_ended(utterance)
                                                             |
                     recognise(samples) -> (Instruction | None, transcript)   (ASR, no side effects)
                                                             |
                     answer(instruction, transcript) -> body                   (the posterior, the decision)

:meth:`StreamListener.feed` only runs the detector (about 1 ms per 32 ms frame), so a caller can
call it from an event loop; :meth:`StreamListener.respond` does the recognition and inference
and blocks, so callers run it in a worker thread while the stream goes on.

**Early recognition.** When the person has been silent for ``post_roll_s`` the utterance's
samples are already final unless speech resumes (the end is only declared after
``min_silence_s``), so the listener starts recognising them then, in its own thread; when the
end is declared and nothing changed, :meth:`respond` takes that result instead of starting
over. If the person speaks again the early result is dropped. With ``version`` (a function
returning a token that changes whenever the answer would, e.g. the number of actions
observed) the answer is computed early too, and used when the token is unchanged at the end;
without it (an answer that writes state, e.g. a session's last answer) the answer always runs
after the end is declared.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar, cast

import numpy as np

from siftom.errors import SiftomError
from siftom.observation import Instruction
from siftom.speech.segment import (
    Event,
    FrameScorer,
    SegmentOptions,
    Utterance,
    UtteranceSegmenter,
)

NO_WORDS = "no words recognised"


@dataclass(frozen=True)
class Recognised:
    """What the recogniser made of an utterance.

    Attributes:
        instruction: the N-best list (and the samples) for the likelihoods; None without words.
        transcript: the engine's transcript (``to_json()``), or None when it was not run.
        seconds: recognition wall time.
        why: why there is no instruction ('' when there is one).
    """

    instruction: Instruction | None
    transcript: Any
    seconds: float
    why: str = ""
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def text(self) -> str:
        return self.transcript.text if self.transcript is not None else ""


class JsonBody(Protocol):
    """What an answer sends: its fields of the ``decision`` event."""

    def to_json(self) -> dict[str, Any]: ...


P = TypeVar("P")  # what ``answer`` prepares
B = TypeVar("B", bound=JsonBody)  # what is sent (``commit``'s result; without commit, what ``answer`` prepares)


@dataclass(frozen=True)
class StreamTimings:
    """Seconds an event took (``None``: not part of this event): ``asr`` and ``answer`` (how long
    each took), ``wait`` (from the call to the answer), ``asr_early`` and ``answer_early`` (whether
    each ran before the end was declared), ``after_speech_s`` (real time: from the last speech frame)."""

    asr: float | None = None
    answer: float | None = None
    wait: float | None = None
    asr_early: bool | None = None
    answer_early: bool | None = None
    after_speech_s: float | None = None

    def to_json(self) -> dict[str, Any]:
        return {k: v for k, v in (("asr", self.asr), ("answer", self.answer), ("wait", self.wait),
                                  ("asr_early", self.asr_early), ("answer_early", self.answer_early),
                                  ("after_speech_s", self.after_speech_s)) if v is not None}


@dataclass(frozen=True)
class NoSpeech:
    """An utterance without words (the recogniser heard none, or none of a request): not answered."""

    utterance: Utterance
    heard: str
    message: str
    timings: StreamTimings

    def to_json(self) -> dict[str, Any]:
        return {"event": "no_speech", **self.utterance.to_json(), "heard": self.heard, "message": self.message,
                "timings": self.timings.to_json()}


@dataclass(frozen=True)
class Decided(Generic[B]):
    """An answered utterance (a ``decision`` event): what was heard, the answer's ``body`` and timings.

    ``utterance`` is None for words recognised elsewhere; ``speech_heard`` and ``message`` are then
    None too (not sent)."""

    utterance: Utterance | None
    heard: str
    nbest: tuple[tuple[str, float], ...]
    body: B
    timings: StreamTimings
    speech_heard: bool | None = None
    message: str | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"event": "decision", **(self.utterance.to_json() if self.utterance else {}),
                               "heard": self.heard, "nbest": [{"text": t, "score": s} for t, s in self.nbest]}
        if self.speech_heard is not None:
            out["speech_heard"] = self.speech_heard
        if self.message is not None:
            out["message"] = self.message
        return {**out, **self.body.to_json(), "timings": self.timings.to_json()}


Recognise = Callable[[np.ndarray], Recognised]
# an early run: what was heard, the state token it was answered under, the answer prepared and its seconds
EarlyResult = tuple[Recognised, Any, tuple[P, float] | None]


class StreamListener(Generic[P, B]):
    """Cut a 16 kHz stream into utterances and answer each (see module doc).

    Args:
        recognise: samples -> :class:`Recognised` (thread-safe, no side effects: it may run early).
        answer: (recognised, utterance) -> the answer prepared (without ``commit``: the body sent,
            whose ``to_json()`` gives the event's posterior, decision, ...).
        options: the segmentation's thresholds and durations.
        scorer: the frame scorer (default: Silero VAD).
        early: start recognising after ``post_roll_s`` of silence (module doc).
        version: with ``early``, answer early too while this token stays the same (module doc);
            ``answer`` must then have no side effects.
        commit: where answering writes state (a session's last answer), ``answer`` prepares it
            without side effects and ``commit(prepared)`` writes it once the end is declared: it returns
            the body to send, or None when the state changed after it was prepared (it is
            prepared again, at most :data:`COMMIT_TRIES` times).
    """

    def __init__(self, recognise: Recognise, answer: Callable[[Recognised, Utterance], P],
                 options: SegmentOptions | None = None, scorer: FrameScorer | None = None, early: bool = True,
                 version: Callable[[], Any] | None = None, commit: Callable[[P], B | None] | None = None) -> None:
        self.segmenter = UtteranceSegmenter(options, scorer)
        self._recognise, self._answer, self.early, self._version = recognise, answer, early, version
        self._commit = commit
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="siftom-early-asr") if early else None
        self._early: tuple[tuple[int, float, int], Future[EarlyResult[P]]] | None = None
        self._lock = threading.Lock()
        self.utterances = 0

    @property
    def options(self) -> SegmentOptions:
        return self.segmenter.options

    def feed(self, chunk: bytes | bytearray | memoryview | np.ndarray) -> list[Event]:
        """Add audio; returns speech_started / speech_ended events (cheap: the detector only)."""
        events = self.segmenter.feed(chunk)
        self._maybe_start_early()
        return events

    def finish(self) -> list[Event]:
        """End of the stream: an utterance in progress ends now."""
        return self.segmenter.finish()

    def close(self) -> None:
        """Stop the early-recognition thread (pending work is dropped)."""
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)

    def _maybe_start_early(self) -> None:
        if self._pool is None:
            return
        preview = self.segmenter.tentative()
        with self._lock:
            if preview is None:
                return
            key = (preview.index, preview.start_s, len(preview.samples))
            if self._early is not None and self._early[0] == key:
                return
            self._early = (key, self._pool.submit(self._early_job, preview))

    def _early_job(self, preview: Utterance) -> EarlyResult[P]:
        rec = self._recognise(preview.samples)
        if self._version is None or rec.instruction is None:
            return rec, None, None
        token = self._version()
        t0 = time.perf_counter()
        body = self._answer(rec, preview)
        return rec, token, (body, time.perf_counter() - t0)

    def respond(self, utterance: Utterance) -> Decided[B] | NoSpeech:
        """Recognise and answer one utterance (blocks).

        Returns a ``decision`` event (:class:`Decided`): the answer's body plus what was heard, the
        utterance's times and ``timings`` in seconds: ``asr`` and ``answer`` (how long each took), ``wait``
        (from this call to the answer: less than their sum when they ran early), ``asr_early``
        and ``answer_early`` (whether each ran before the end was declared). An utterance without words (the
        second detector found no speech in it, or the recogniser no words) gives a ``no_speech``
        event (:class:`NoSpeech`) instead and is not answered.
        """
        t0 = time.perf_counter()
        key = (utterance.index, utterance.start_s, len(utterance.samples))
        early = None
        with self._lock:
            if self._early is not None and self._early[0] == key:
                early = self._early[1]
            self._early = None
        rec: Recognised | None = None
        token: Any = None
        early_body: tuple[P, float] | None = None
        if early is not None:
            try:
                rec, token, early_body = early.result()
            except Exception:  # the early run failed: recognise again below, where errors surface
                rec = None
        if rec is None:
            rec = self._recognise(utterance.samples)
        t1 = time.perf_counter()
        if rec.instruction is None:  # noise, a cough, words outside any phrasing: nothing to answer
            return NoSpeech(utterance, rec.text, rec.why,
                            StreamTimings(asr=round(rec.seconds, 4), wait=round(t1 - t0, 4), asr_early=early is not None))
        answered_early = early_body is not None and self._version is not None and self._version() == token
        if answered_early and early_body is not None:
            prepared, answer_s = early_body
        else:  # nothing was answered early, or the state changed since (a new action)
            prepared = self._answer(rec, utterance)
            answer_s = time.perf_counter() - t1
        body = self._committed(prepared, rec, utterance)
        t2 = time.perf_counter()
        self.utterances += 1
        nbest = tuple((h.text, round(float(h.score), 4)) for h in rec.instruction.nbest)
        return Decided(utterance, rec.text, nbest, body,
                       StreamTimings(asr=round(rec.seconds, 4), answer=round(answer_s, 4), wait=round(t2 - t0, 4),
                                     asr_early=early is not None, answer_early=answered_early),
                       speech_heard=True, message=rec.why)

    def _committed(self, prepared: P, rec: Recognised, utterance: Utterance) -> B:
        """``prepared`` written by ``commit``; prepared again while the state moves under it.
        Without ``commit`` what was prepared is sent."""
        commit = self._commit
        if commit is None:
            return cast(B, prepared)  # without commit, what is prepared is sent
        for _ in range(COMMIT_TRIES):
            done = commit(prepared)
            if done is not None:
                return done
            prepared = self._answer(rec, utterance)
        raise SiftomError(f"the session changed under {COMMIT_TRIES} answers in a row (actions arriving faster than "
                          "an answer); say it again")


COMMIT_TRIES = 3  # a prepared answer made stale by an action: prepared again at most this often


def recogniser(engine: Any, nbest: int, lock: Any = None) -> Recognise:
    """Recognition of an utterance the detector cut: ``engine`` (e.g. pocketsphinx biased to the
    home's phrasings) gives the N-best list and word times; no words gives no instruction.
    ``lock`` guards an engine shared between threads."""

    guard = lock if lock is not None else threading.Lock()

    def run(samples: np.ndarray) -> Recognised:
        t0 = time.perf_counter()
        with guard:
            tr = engine.transcribe(samples, nbest=nbest)
        if not tr.text:
            return Recognised(None, tr, time.perf_counter() - t0, NO_WORDS)
        instruction = tr.to_instruction(samples=samples)
        return Recognised(instruction, tr, time.perf_counter() - t0)

    return run
