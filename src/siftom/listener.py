"""A robot in one home, listening: a :class:`~siftom.inference.stream.StreamListener` over a
scenario or a world, with the person's actions arriving at any time.

Used by ``siftom listen`` (microphone or WAV file), the ROS bridge and ``siftom bench stream``;
the WebSocket endpoint uses the same listener over a session (:mod:`siftom.service.stream_api`).
Nothing here needs the ``serve`` extra.

Each answered utterance is a ``decision`` event in the one answer shape (``siftom.answer``):
the posterior (``commands``, ``goals``, ``top_command``), the decision rule's ``decision`` and
``action``, one of

* ``act``: carry out ``command``;
* ``ask``: ask ``question`` first (the rule found a question worth its time);
* ``none``: do nothing (no instruction heard, or no command worth its risk; ``command`` is null).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from siftom.answer import Answer
from siftom.assist.clarify import Clarification, ClarifyPolicy, clarify
from siftom.assist.reply import Pending
from siftom.errors import ObservationError
from siftom.inference.stream import (
    Decided,
    NoSpeech,
    Recognised,
    StreamListener,
    StreamTimings,
    recogniser,
)
from siftom.observer import Observer
from siftom.speech.segment import FrameScorer, SegmentOptions, SpeechEnded, SpeechStarted, Utterance

ACTIONS = ("act", "ask", "none")


def load_home(scenario: str | None = None, scene: str | Path | None = None) -> Any:
    """A registered scenario (the listener observes its recorded actions first, as ``siftom
    infer`` does) or a world JSON / VirtualHome scene graph file, as a scene for :class:`HomeListener`."""
    if (scenario is None) == (scene is None):
        raise ObservationError("give exactly one of a scenario id (--scenario) or a world file (--scene)")
    if scenario is not None:
        from siftom.scenarios.base import get_scenario

        return get_scenario(scenario)
    from siftom.world.io import load_scene

    return load_scene(scene)  # type: ignore[arg-type]


class HomeListener:
    """One home's listener: stream audio in, observe action lines, get decision events.

    Every answer is the observer's (:meth:`siftom.Observer.answer`): the same posterior and
    decision as ``siftom.infer`` on the same words and actions.

    Args:
        home: a Scenario (its recorded actions are observed first, unless ``recorded`` is False)
            or a loaded scene (:func:`load_home`).
        observer: the observer to answer with (default: the shared one for the settings in force).
        mode, likelihood, decide, top, nbest, engine: left out, the settings (``model.mode``,
            ``infer.likelihood``, ``infer.decide``, ``infer.top``, ``infer.nbest``, ``infer.engine``).
            Words recognised elsewhere (:meth:`answer_text`) are scored by their phonemes.
        policy: the clarifying policy of the ``clarification`` field (``ClarifyPolicy``).
        options, scorer, early: the segmentation (:class:`StreamListener`).
    """

    def __init__(self, home: Any, *, observer: Observer | None = None, mode: str | None = None,
                 likelihood: str | None = None, top: int | None = None, policy: ClarifyPolicy | None = None,
                 options: SegmentOptions | None = None, scorer: FrameScorer | None = None, early: bool = True,
                 engine: str | None = None, nbest: int | None = None, decide: str | None = None,
                 recorded: bool = True) -> None:
        from siftom.observer import observer_for

        self.observer = observer if observer is not None else observer_for()
        st = self.observer.settings
        self.home, self.policy = home, policy or ClarifyPolicy()
        self.top = top or st.infer.top
        self.world, self.verb = home.world, getattr(home, "verb", "deliver")
        self.mode = mode or st.model.mode
        self.likelihood_arg, self.decide = likelihood, decide
        resolved, self.likelihood_reason = self.observer.resolve(likelihood, has_audio=True)
        self.likelihood = resolved if isinstance(resolved, str) else type(resolved).__name__
        self.online = self.observer.fresh(home.world, home.start, tuple(home.goals), self.verb, self.mode)
        self.actions: list[str] = []
        self.pending: Pending | None = None  # the question the robot asked last and waits on
        self._lock = threading.Lock()  # the online inference and the pending question
        for a in getattr(home, "actions", ()) if recorded else ():  # a scenario's recorded actions so far
            self.online.observe(a)
            self.actions.append(self.world.format_action(a))
        rec = self.observer.recogniser(self.world, self.verb, engine)
        self.listener: StreamListener[HomeAnswer, HomeAnswer] = StreamListener(recogniser(rec.engine, nbest or st.infer.nbest, rec.lock), self._answer,
                                       options, scorer, early,
                                       version=lambda: (len(self.actions), id(self.pending)))  # answer early

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
    def feed(self, chunk: Any) -> list[SpeechStarted | SpeechEnded]:
        return self.listener.feed(chunk)

    def finish(self) -> list[SpeechStarted | SpeechEnded]:
        return self.listener.finish()

    def respond(self, utterance: Utterance) -> Decided[HomeAnswer] | NoSpeech:
        return self._kept(self.listener.respond(utterance))

    def _kept(self, event: Decided[HomeAnswer] | NoSpeech) -> Decided[HomeAnswer] | NoSpeech:
        """Keep the question an answer leaves waiting (an answer made early, then used, included)."""
        if isinstance(event, Decided):
            with self._lock:
                self.pending = event.body.pending
        return event

    def close(self) -> None:
        self.listener.close()

    def answer_text(self, text: str) -> Decided[HomeAnswer]:
        """Answer words recognised elsewhere (e.g. a robot's own ASR) as one utterance's transcript."""
        from siftom.observation import Hypothesis, Instruction

        if not text.strip():
            raise ObservationError("the text is empty; give the words that were heard")
        t0 = time.perf_counter()
        rec = Recognised(Instruction(nbest=(Hypothesis(text.strip(), 0.0),)), None, 0.0)
        body = self._answer(rec, None, text_only=True)
        total = round(time.perf_counter() - t0, 4)
        event = Decided(None, text.strip(), ((text.strip(), 0.0),), body, StreamTimings(answer=total, wait=total))
        self._kept(event)
        return event

    def _answer(self, rec: Recognised, utterance: Utterance | None, text_only: bool = False) -> HomeAnswer:
        from siftom.observer import Heard

        likelihood = self.likelihood_arg
        if text_only and likelihood == "acoustic":  # no sound to score: the words' phonemes
            likelihood = "phonetic"
        heard = None if text_only else Heard(rec.instruction, rec.transcript, None, {"asr": rec.seconds})
        with self._lock:
            t0 = time.perf_counter()
            ans = self.observer.answer(self.online, rec.instruction, likelihood=likelihood, decide=self.decide,
                                       top=self.top, heard=heard, mode=self.mode, pending=self.pending)
            n = len(self.actions)
        return HomeAnswer(ans, self.top, clarify(ans.commands, self.policy), n, round(time.perf_counter() - t0, 4))


@dataclass(frozen=True)
class HomeAnswer:
    """A home's answer to one utterance: the observer's answer, the clarifying policy's view of it,
    the number of actions it was given and how long it took (the body of a ``decision`` event)."""

    answer: Answer
    top: int
    clarification: Clarification
    n_actions: int
    infer_s: float

    @property
    def pending(self) -> Pending | None:
        """The question the answer leaves waiting (kept by the listener, not sent)."""
        return self.answer.pending

    def to_json(self) -> dict[str, Any]:
        ans = self.answer
        body = ans.to_json(top=self.top)
        body["clarification"] = self.clarification.to_json()
        body["question"] = ans.decision.question if ans.action == "ask" else ""
        body["declined"] = ans.decision.declined  # what the robot says when it turns the request down
        body["prob"] = ans.prob(ans.command) if ans.command is not None else 0.0
        body["n_actions"] = self.n_actions
        body["infer_s"] = self.infer_s
        return body


@dataclass(frozen=True)
class ListenerError:
    """Something that went wrong while listening (one utterance, one line or message): said, then
    the listening goes on. At most one of ``topic``, ``line``, ``heard``, ``actions`` says what it was about."""

    detail: str
    utterance: Utterance | None = None
    topic: str | None = None
    line: str | None = None
    heard: str | None = None
    actions: tuple[str, ...] | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"event": "error", **(self.utterance.to_json() if self.utterance else {})}
        for k, v in (("topic", self.topic), ("line", self.line), ("heard", self.heard)):
            if v is not None:
                out[k] = v
        if self.actions is not None:
            out["actions"] = list(self.actions)
        out["detail"] = self.detail
        return out


@dataclass(frozen=True)
class ActionsObserved:
    """The person's actions just observed (siftom's form) and how many there are now."""

    added: tuple[str, ...]
    n_actions: int

    def to_json(self) -> dict[str, Any]:
        return {"event": "actions", "added": list(self.added), "n_actions": self.n_actions}


# what a listener says: speech started and ended, answers, actions observed, errors
ListenEvent = SpeechStarted | SpeechEnded | Decided[HomeAnswer] | NoSpeech | ListenerError | ActionsObserved

COMPACT = ("event", "utterance", "start_s", "end_s", "ended_s", "reason", "heard", "nbest", "command", "prob",
           "action", "carry_out", "top_command", "question", "declined", "reply_to", "awaiting_reply", "commands",
           "goals", "n_actions", "message", "recogniser", "likelihood", "rule", "timings")


@dataclass(frozen=True)
class Compact:
    """An event as one line of output: the fields worth it (what was heard, command, decision,
    timings), the N-best list cut to ``nbest`` (what ``siftom listen --json`` prints and the ROS
    bridge publishes)."""

    event: ListenEvent
    nbest: int = 3

    def to_json(self) -> dict[str, Any]:
        full = self.event.to_json()
        out = {k: full[k] for k in COMPACT if k in full}
        if "nbest" in out:
            out["nbest"] = out["nbest"][:self.nbest]
        return out


def run_listener(home: HomeListener, chunks: Iterable[Any], emit: Callable[[ListenEvent], None], *,
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
            emit(ListenerError(f"{type(exc).__name__}: {exc}", utterance=utt))
            return
        if realtime:
            after = round(utt.ended_s - utt.end_s + time.perf_counter() - declared, 4)
            out = replace(out, timings=replace(out.timings, after_speech_s=after))
        emit(out)

    def handle(evs: list[SpeechStarted | SpeechEnded]) -> None:
        nonlocal count
        for ev in evs:
            if events:
                emit(ev)
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
