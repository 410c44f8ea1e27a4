"""A robot in one home, listening: a :class:`~siftom.inference.stream.StreamListener` over a
scenario or a world, with the person's actions arriving at any time.

Used by ``siftom listen`` (microphone or WAV file), the ROS bridge and ``siftom bench stream``;
the WebSocket endpoint uses the same listener over a session (:mod:`siftom.service.stream_api`).
Nothing here needs the ``serve`` extra.

Each answered utterance is a ``decision`` event: the posterior (``command``, ``commands``,
``goals``), the clarifying question when asking pays, and ``decision``, one of

* ``act``: carry out ``command``;
* ``ask``: ask ``question`` first (the posterior is too flat, docs/service.md);
* ``wait``: do nothing yet (a decision rule found no command worth its cost).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from siftom.assist.clarify import ClarifyPolicy, clarify
from siftom.errors import ObservationError
from siftom.inference.stream import Recognised, StreamListener, recogniser
from siftom.speech.asr import DEFAULT_NBEST
from siftom.speech.segment import FrameScorer, SegmentOptions, SpeechEnded, Utterance

DECISIONS = ("act", "ask", "wait")


def decision_kind(body: dict[str, Any]) -> str:
    """``act``, ``ask`` or ``wait`` from an answer's ``clarification`` and optional ``decision``."""
    rule = body.get("decision")
    if isinstance(rule, dict) and rule.get("action") in ("none", "ask"):
        return "wait" if rule["action"] == "none" else "ask"
    if (body.get("clarification") or {}).get("ask"):
        return "ask"
    return "act"


def load_home(scenario: str | None = None, scene: str | Path | None = None) -> Any:
    """A registered scenario (its recorded actions are *not* taken: a live robot observes its
    own) or a world JSON / VirtualHome scene graph file, as a scene for :class:`HomeListener`."""
    if (scenario is None) == (scene is None):
        raise ObservationError("give exactly one of a scenario id (--scenario) or a world file (--scene)")
    if scenario is not None:
        from siftom.scenarios.base import get_scenario

        return get_scenario(scenario)
    from siftom.world.io import load_scene

    return load_scene(scene)  # type: ignore[arg-type]


class HomeListener:
    """One home's listener: stream audio in, observe action lines, get decision events.

    Args:
        home: a Scenario or a loaded scene (:func:`load_home`).
        mode, likelihood: the model (``phonetic``, ``acoustic`` or ``llm``; ``auto``, the default:
            acoustic when the whisper extra is installed, else phonetic; words recognised elsewhere,
            :meth:`answer_text`, are scored by their phonemes).
        top: commands and goals in each answer.
        policy: when to ask (``ClarifyPolicy``).
        options, scorer, early: the segmentation (:class:`StreamListener`).
        engine: the recogniser (pocketsphinx biased to the home's phrasings by default).
    """

    def __init__(self, home: Any, *, mode: str = "full", likelihood: str = "auto", top: int = 5,
                 policy: ClarifyPolicy | None = None, options: SegmentOptions | None = None,
                 scorer: FrameScorer | None = None, early: bool = True, engine: str = "pocketsphinx",
                 nbest: int = DEFAULT_NBEST) -> None:
        from siftom.api import engine_for, get_model
        from siftom.likelihood.registry import resolve_likelihood

        self.home, self.top, self.policy = home, top, policy or ClarifyPolicy()
        self.world, self.verb = home.world, getattr(home, "verb", "deliver")
        likelihood, self.likelihood_reason = resolve_likelihood(likelihood, has_audio=True)
        self.mode, self.likelihood = mode, likelihood
        self.online = get_model(mode, likelihood).online(home.world, home.start, tuple(home.goals), self.verb)
        self.actions: list[str] = []
        self._lock = threading.Lock()  # the online inference and the likelihood's caches
        asr = engine_for(self.world, self.verb, engine)
        self.listener = StreamListener(recogniser(asr, nbest), self._answer, options, scorer, early,
                                       version=lambda: len(self.actions))  # answers are pure: answer early

    # ----- actions ---------------------------------------------------------------------------
    def observe(self, lines: Sequence[str]) -> list[str]:
        """Add the person's actions (siftom or VirtualHome script lines), all or none; returns
        them in siftom's form (an impossible or unreadable line raises ObservationError)."""
        from siftom.world.vhscript import parse_actions

        with self._lock:
            acts, _ = parse_actions(self.world, self.online.state, list(lines), first=0)
            for a in acts:
                self.online.observe(a)
            texts = [self.world.format_action(a) for a in acts]
            self.actions.extend(texts)
        return texts

    # ----- audio -----------------------------------------------------------------------------
    def feed(self, chunk: Any) -> list[Any]:
        return self.listener.feed(chunk)

    def finish(self) -> list[Any]:
        return self.listener.finish()

    def respond(self, utterance: Utterance) -> dict[str, Any]:
        return self.listener.respond(utterance)

    def close(self) -> None:
        self.listener.close()

    def answer_text(self, text: str) -> dict[str, Any]:
        """Answer words recognised elsewhere (e.g. a robot's own ASR) as one utterance's transcript."""
        from siftom.observation import Hypothesis, Instruction

        if not text.strip():
            raise ObservationError("the text is empty; give the words that were heard")
        t0 = time.perf_counter()
        rec = Recognised(Instruction(nbest=(Hypothesis(text.strip(), 0.0),)), None, 0.0)
        body = self._answer(rec, None, text_only=True)
        total = round(time.perf_counter() - t0, 4)
        return {"event": "decision", "heard": text.strip(), "nbest": [{"text": text.strip(), "score": 0.0}],
                "speech_heard": True, "message": "", **body, "timings": {"answer": total, "wait": total}}

    def _answer(self, rec: Recognised, utterance: Utterance | None, text_only: bool = False) -> dict[str, Any]:
        with self._lock:
            t0 = time.perf_counter()
            online = self.online
            if text_only and self.likelihood == "acoustic":  # no sound to score: the words' phonemes
                import copy

                from siftom.api import get_model

                online = copy.copy(self.online)  # posterior() only reads the action state
                online.model = get_model(self.mode, "phonetic")
            post = online.posterior(rec.instruction, top=self.top)
            n = len(self.actions)
        body: dict[str, Any] = post.to_json(top=self.top)
        body["clarification"] = clarify(post.commands, self.policy).to_json()
        body["decision"] = decision_kind(body)
        body["question"] = body["clarification"]["question"] if body["decision"] == "ask" else ""
        body["prob"] = post.prob(post.command)
        body["n_actions"] = n
        body["infer_s"] = round(time.perf_counter() - t0, 4)
        return body


COMPACT = ("event", "utterance", "start_s", "end_s", "ended_s", "reason", "heard", "nbest", "command", "prob",
           "decision", "question", "commands", "goals", "n_actions", "message", "timings")


def compact(answer: dict[str, Any], nbest: int = 3) -> dict[str, Any]:
    """The fields of an answer worth one line of output (what was heard, command, decision, timings)."""
    out = {k: answer[k] for k in COMPACT if k in answer}
    if "nbest" in out:
        out["nbest"] = out["nbest"][:nbest]
    return out


def run_listener(home: HomeListener, chunks: Iterable[Any], emit: Callable[[dict[str, Any]], None], *,
                 realtime: bool = False, events: bool = False) -> int:
    """Feed ``chunks`` to ``home``; answer each utterance in a worker thread, in order, while the
    audio goes on; ``emit`` each answer (from that thread). With ``realtime`` (the chunks arrive
    as they are spoken: a microphone, a file played in real time) each answer's timings carry
    ``after_speech_s``: the detector's wait after the last speech frame plus the wall time from
    the end being declared to the answer. ``events``: emit speech_started/ended too. Returns the
    number of utterances answered or found empty."""
    pool = ThreadPoolExecutor(1, thread_name_prefix="siftom-answer")
    count = 0

    def answer(utt: Utterance, declared: float) -> None:
        try:
            out = home.respond(utt)
        except Exception as exc:  # one utterance failed (e.g. a backend error): say so, go on
            emit({"event": "error", **utt.to_json(), "detail": f"{type(exc).__name__}: {exc}"})
            return
        if realtime:
            out["timings"]["after_speech_s"] = round(utt.ended_s - utt.end_s + time.perf_counter() - declared, 4)
        emit(out)

    def handle(evs: list[Any]) -> None:
        nonlocal count
        for ev in evs:
            if events:
                emit(ev.to_json())
            if isinstance(ev, SpeechEnded):
                count += 1
                pool.submit(answer, ev.utterance, time.perf_counter())

    try:
        for chunk in chunks:
            handle(home.feed(chunk))
        handle(home.finish())
    finally:
        pool.shutdown(wait=True)
    return count
