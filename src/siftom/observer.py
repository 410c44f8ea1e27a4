"""The observer: one object, built from :class:`~siftom.settings.Settings`, behind every door.

An :class:`Observer` owns the SIFToM models (one per mode and likelihood), the recognisers (one
per scene vocabulary), the online inferences of the scenes it has seen (the action term, built
once per scene and actions) and the decision rule. Its calls are what a robot needs:

* :meth:`Observer.infer`: a scene, the person's actions and what was heard (a transcript, an
  N-best list, a recording or samples) to an :class:`~siftom.answer.Answer`;
* :meth:`Observer.listen`: the same from a recording, with the recogniser's output and timings;
* :meth:`Observer.answer`: what was heard, on an online inference a caller keeps (a session, a
  stream) and advances with the person's actions;
* :meth:`Observer.hear`: voice-activity detection and recognition of a clip.

``siftom.infer`` and ``siftom.listen`` are one-shot uses of an observer (as ``httpx.get`` is of
a ``Client``); the CLI, the HTTP service, its sessions and streams, the ROS bridge and the
evaluator's model rows each hold one. A per-call argument left out means "the setting".

The robot does nothing it was not asked to do: when a recording holds no speech, or the words
are near no command of the scene, the answer's action is ``none`` whatever the rule, and the
posterior is the one from the actions alone (its most probable command stays readable as
``top_command``).
"""

from __future__ import annotations

import copy
import dataclasses
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siftom.answer import NOTHING_ASKED, Answer
from siftom.assist.decide import Decision, DecisionRule, MapRule, Situation, get_rule
from siftom.assist.questions import Question, reliability_for
from siftom.assist.reply import REPLY_RELIABILITY, Pending
from siftom.assist.requested import (
    combine_parts,
    one_command_once,
    request_parts,
    said_object,
    words_refused,
    written_absent,
)
from siftom.assist.teamvalue import NONE
from siftom.assist.unsure import ask_if_unsure
from siftom.errors import ObservationError, unknown_name
from siftom.inference.listen import NO_INSTRUCTION, NO_SPEECH, with_likelihood
from siftom.inference.model import OnlineInference, Posterior, SIFToM
from siftom.inference.understood import typed
from siftom.inputs import SceneInput
from siftom.language.record import Mention
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.memo import Memo
from siftom.settings import Settings
from siftom.world.commands import RobotCommand
from siftom.world.model import State, World

LikelihoodArg = str | InstructionLikelihood
MAX_PARTS = 3  # the most objects one request carries out (a request naming more: the first three)
MODES = ("full", "speech-only", "action-only")


@dataclass
class Recogniser:
    """A speech recogniser and the lock that keeps it to one utterance at a time."""

    engine: Any
    lock: threading.Lock = field(default_factory=threading.Lock)

    def transcribe(self, samples: np.ndarray, nbest: int) -> Any:
        """The N-best transcript of ``samples`` (16 kHz mono)."""
        with self.lock:
            return self.engine.transcribe(samples, nbest=nbest)


@dataclass(frozen=True)
class Heard:
    """What :meth:`Observer.hear` made of a clip: the instruction (None without speech or
    words), the recogniser's output, the detector's result and the seconds each stage took."""

    instruction: Instruction | None
    asr: Any
    vad: Any
    timings: dict[str, float]

    @property
    def speech(self) -> bool:
        return self.vad is None or bool(self.vad.speech)


# the built-in likelihoods that take a lexicon (a world's own names of its classes)
NAMED_BY_LEXICON = ("phonetic", "acoustic", "llm")


def build_model(settings: Settings, mode: str, likelihood: LikelihoodArg, lexicon: Any = None) -> SIFToM:
    """A SIFToM model from ``settings`` for ``mode`` and ``likelihood`` (a name or an object);
    ``lexicon``: how the world names its classes (None: the built-in lexicon)."""
    from siftom.likelihood.registry import get_likelihood

    cfg = dataclasses.replace(settings.model, mode=mode)
    if not cfg.uses_speech:
        return SIFToM(cfg, None)
    if not isinstance(likelihood, str):
        if not isinstance(likelihood, InstructionLikelihood):
            raise ObservationError(
                f"likelihood must be a name ('phonetic', 'acoustic', 'llm') or an object with "
                f"log_prob(instruction, commands), got {type(likelihood).__name__}")
        return SIFToM(cfg, likelihood)
    options = settings.likelihood_options(likelihood)
    if lexicon is not None and likelihood in NAMED_BY_LEXICON:
        options["lexicon"] = lexicon
    if likelihood == "llm":
        options = {"backend": settings.llm, **options}
    return SIFToM(cfg, get_likelihood(likelihood, **options))


def _lexicon_of(world: World) -> Any:
    """The lexicon of a world that names its classes itself; None for the built-in one."""
    if not world.names:
        return None
    from siftom.likelihood.lexicon import lexicon_for

    return lexicon_for(world)


@dataclass(frozen=True)
class _Call:
    """One :meth:`Observer.answer` call's resolved options (the settings where the call named none)."""

    mode: str
    likelihood: LikelihoodArg
    why: str  # why that likelihood ran
    top: int
    decide: str | DecisionRule | None
    heard: Heard | None
    reliability: float | Mapping[str, float]
    t0: float


class Observer:
    """The model, recognisers, likelihoods and per-scene caches of one robot, from one settings object.

    Args:
        settings: every option (default: :meth:`Settings.load`: ``SIFTOM_CONFIG`` and ``SIFTOM_*``).
        offered: the instruction likelihoods this observer may run (default: any registered one);
            a service offers a subset.
        max_audio_seconds: the longest clip a recogniser accepts.
        decode_in_worker: scene recognisers decode in a warm worker process (the same transcript;
            a server's other threads keep the GIL meanwhile).

    Thread-safe: models and likelihoods keep nothing between calls; a recogniser holds one
    utterance at a time behind its lock; the caches create outside their locks.
    """

    def __init__(self, settings: Settings | None = None, *, offered: Sequence[str] | None = None,
                 max_audio_seconds: float | None = None, decode_in_worker: bool = False) -> None:
        self.settings = settings if settings is not None else Settings.load()
        # a server: scene recognisers decode in a worker process, the same transcript without
        # holding the GIL its other requests need (speech/asr/worker.py, WorkerEngine)
        self.decode_in_worker = decode_in_worker
        self.offered = tuple(offered) if offered is not None else None
        self.max_audio_seconds = max_audio_seconds
        self._models: dict[Any, SIFToM] = {}
        self._models_lock = threading.Lock()
        self._recognisers: Memo[Recogniser] = Memo("observer.recognisers", 8)
        self._online: Memo[OnlineInference] = Memo("observer.online", 256)

    # ----- parts ------------------------------------------------------------------------------
    def model(self, mode: str | None = None, likelihood: LikelihoodArg = "phonetic", lexicon: Any = None) -> SIFToM:
        """The model for ``mode`` (default: the setting), ``likelihood`` and ``lexicon`` (a
        world's own names; None: the built-in lexicon), built once."""
        mode = mode or self.settings.model.mode
        if mode not in MODES:
            raise unknown_name("model mode", mode, MODES)
        key = (mode, likelihood if isinstance(likelihood, str) else ("object", id(likelihood)),
               None if lexicon is None else lexicon.fingerprint)
        with self._models_lock:
            got = self._models.get(key)
        if got is not None:
            return got
        model = build_model(self.settings, mode, likelihood, lexicon)
        with self._models_lock:
            return self._models.setdefault(key, model)

    def resolve(self, likelihood: LikelihoodArg | None, has_audio: bool) -> tuple[LikelihoodArg, str]:
        """(likelihood to run, why): None is the setting ``infer.likelihood``; ``auto`` the best
        one the input allows (acoustic for audio with the whisper extra, else phonetic)."""
        from siftom.likelihood.registry import AUTO, resolve_likelihood

        if likelihood is not None and not isinstance(likelihood, str):
            return likelihood, "given as an object"
        name = likelihood if likelihood is not None else self.settings.infer.likelihood
        if name != AUTO:
            self.check_likelihood(name)
            return resolve_likelihood(name, has_audio)
        if has_audio and self.offered is not None and "acoustic" not in self.offered:
            has_audio = False
        return resolve_likelihood(None, has_audio)

    def check_likelihood(self, name: str) -> None:
        """Refuse a likelihood this observer does not offer (an unknown name suggests close ones)."""
        from siftom.likelihood.registry import AUTO, LIKELIHOODS

        if name == AUTO:
            return
        if self.offered is not None and name not in self.offered:
            raise ObservationError(str(unknown_name("instruction likelihood on this server", name, self.offered)))
        LIKELIHOODS.spec(name)

    def recogniser(self, world: World, verb: str, engine: str | None = None) -> Recogniser:
        """The recogniser for a scene (a scene engine such as pocketsphinx is biased to its
        command phrasings), built once per vocabulary."""
        from siftom.likelihood.phrasing import command_vocabulary
        from siftom.speech.asr.base import get_engine, is_scene_engine

        name = engine or self.settings.infer.engine
        opts: dict[str, Any] = {}
        if name == "pocketsphinx" and self.max_audio_seconds is not None:
            opts["max_seconds"] = self.max_audio_seconds
        if name != "pocketsphinx" and not is_scene_engine(name):  # pocketsphinx takes an optional vocabulary
            return self._recognisers.get((name,), lambda: Recogniser(get_engine(name, **opts)))
        vocab = tuple(sorted(command_vocabulary(world.classes, verb, lexicon=_lexicon_of(world))))

        def build() -> Recogniser:
            engine = get_engine(name, vocabulary=list(vocab), **opts)
            if self.decode_in_worker:
                from siftom.speech.asr.worker import WorkerEngine

                engine = WorkerEngine(engine, name, list(vocab), **opts)
            return Recogniser(engine)

        return self._recognisers.get((name, vocab), build)

    def online(self, scene: SceneInput, mode: str | None = None) -> OnlineInference:
        """The online inference of ``scene`` with its actions observed, built once per scene and
        actions (the action term does not depend on the instruction likelihood: :meth:`answer`
        scores what was heard with the likelihood it resolves)."""
        model = self.model(mode, "phonetic")

        def make() -> OnlineInference:
            on = model.online(scene.world, scene.start, scene.goals, scene.verb)
            for a in scene.actions:
                on.observe(a)
            return on

        got: OnlineInference = self._online.get((scene.key, model.config.mode), make)
        return got

    def fresh(self, world: World, start: State, goals: Sequence[Any], verb: str, mode: str | None = None) -> OnlineInference:
        """A new online inference for a caller to advance (a session, a stream)."""
        return self.model(mode, "phonetic").online(world, start, tuple(goals), verb)

    # ----- hearing ----------------------------------------------------------------------------
    def hear(self, samples: np.ndarray, world: World, verb: str, *, engine: str | None = None,
             nbest: int | None = None) -> Heard:
        """Detect speech in ``samples``, cut to it and recognise it."""
        from siftom.inference.listen import hear

        rec = self.recogniser(world, verb, engine)
        instruction, tr, vad, timings = hear(samples, _Locked(rec), nbest or self.settings.infer.nbest)
        return Heard(instruction, tr, vad, timings)

    # ----- answers ----------------------------------------------------------------------------
    def answer(self, online: OnlineInference, instruction: Instruction | None, *,
               likelihood: LikelihoodArg | None = None, decide: str | DecisionRule | None = None,
               top: int | None = None, heard: Heard | None = None, mode: str | None = None,
               gate: bool = True, pending: Pending | None = None,
               answer_reliability: float | Mapping[str, float] | None = None) -> Answer:
        """What the robot does about ``instruction`` on ``online`` (its actions observed so far).

        ``heard``: the clip the instruction was recognised from (no speech: ``instruction`` None).
        ``likelihood``, ``decide``, ``top`` and ``mode`` left out are the settings. ``gate``
        False keeps the words' posterior when they hold no instruction (the paper's model, for
        the evaluator's accuracy of the inferred command); the action is still ``none``.
        ``pending``: the question the robot asked last and waits on (``answer.pending`` of the
        answer that asked it): words that reply to it are weighed with the request's
        (assist/reply.py). The answer's ``pending`` is what to keep for the next utterance.
        ``answer_reliability``: how often a spoken answer to a question is heard as the cell it
        names, one number or one per kind (default: the measured clean values,
        ``assist.reply.REPLY_RELIABILITY``); the questions' value and the reply's update use it.
        """
        t0 = time.perf_counter()
        top = top or self.settings.infer.top
        mode = mode or online.model.config.mode
        lk, why = self.resolve(likelihood, instruction is not None and instruction.has_audio)
        rel = REPLY_RELIABILITY if answer_reliability is None else answer_reliability
        call = _Call(mode, lk, why, top, decide, heard, rel, t0)
        if pending is not None and instruction is not None and mode != "speech-only":
            replied = self._reply(online, pending, instruction, call)
            if replied is not None:
                return replied
        speech = None if heard is None else heard.speech
        post, said = self._heard_posterior(online, instruction, call, gate)
        world, target = online.world, online.goals[0].target
        nothing = (NO_SPEECH if speech is False else NO_INSTRUCTION if not said
                   else NOTHING_ASKED if instruction is None else "")
        understood = post.understanding if said and instruction is not None else None
        if understood is not None and understood.request and instruction is not None and typed(instruction) \
                and mode != "speech-only":
            # written words are not misheard: a word like no object here may name one that is not
            understood = written_absent(understood, online.world, _lexicon_of(online.world), post)
            post = dataclasses.replace(post, understanding=understood)
        targets = understood.targets if understood is not None and understood.request else ()
        named, left_out = request_parts(targets, MAX_PARTS)
        parts: tuple[RobotCommand, ...] = ()
        decisions: list[Decision] = []
        part_posts: list[Posterior] = []
        if len(named) > 1 and instruction is not None and not nothing and mode != "speech-only":
            # several things in one request: each target read on its own (its slot alone is
            # scored), decided on its own; the robot carries out every part it would act on
            view = self._view(online, mode, lk)
            part_posts = [with_likelihood(view.posterior(dataclasses.replace(instruction, focus=k), top=top),
                                          lk if isinstance(lk, str) else type(lk).__name__, why)
                          for k in named]
            decided = [self._decide_part(pp, world, target, decide, targets[k], rel, online.verb)
                       for pp, k in zip(part_posts, named, strict=True)]
            decisions, parts = one_command_once([d for d, _ in decided], tuple(c for _, c in decided))
            decision = combine_parts(decisions, left_out, MAX_PARTS)
        else:
            if targets:
                parts = (post.command,)
            decision = self.decide(post, world, target, decide, nothing=nothing, answer_reliability=rel)
            if targets and not nothing:
                decision, parts = said_object(decision, parts, targets[0], post, world, target, online.verb)
        post = dataclasses.replace(post, evidence={**post.evidence, "parts": [str(c) for c in parts]})
        post = dataclasses.replace(post, decision=decision)
        asking = next((pp for pp, d in zip(part_posts, decisions, strict=True) if d.action == "ask"), post) \
            if decisions else post
        keep = self._pending(online, asking, decision, mode, refused=words_refused(asking)) \
            if decision.action == "ask" else (
            pending if nothing else None)  # words that asked nothing leave a question waiting
        timings = {**(heard.timings if heard is not None else {}), "infer": time.perf_counter() - t0}
        return Answer(post, decision, speech, heard.asr if heard is not None else None,
                      heard.vad if heard is not None else None, time.perf_counter() - t0, timings, said, parts,
                      tuple(decisions), keep)

    def _heard_posterior(self, online: OnlineInference, instruction: Instruction | None, call: _Call,
                         gate: bool) -> tuple[Posterior, bool]:
        """(the posterior, whether an instruction was said): from the actions alone when nothing,
        no words or words near no command of the scene were heard (``gate`` False keeps the
        words' posterior then; see :meth:`answer`)."""
        mode, lk, why, top, heard = call.mode, call.likelihood, call.why, call.top, call.heard
        said = not (heard is not None and heard.speech and instruction is None)  # speech, but no words
        if instruction is None:
            post = self._view(online, "action-only" if mode != "speech-only" else mode, "phonetic").posterior(
                None, top=top, heard_nothing=heard is not None)
        else:
            post = with_likelihood(self._view(online, mode, lk).posterior(instruction, top=top),
                                   lk if isinstance(lk, str) else type(lk).__name__, why)
            if post.evidence.get("no_instruction") and mode != "speech-only":
                # words, but none near a command of the scene: the actions alone, and no command issued
                said = False
            if not said and gate and mode != "speech-only":
                alone = self._view(online, "action-only", "phonetic").posterior(None, top=top)
                post = dataclasses.replace(alone, transcript=post.transcript, evidence=post.evidence,
                                           understanding=post.understanding)
        if heard is not None:
            post = dataclasses.replace(post, evidence={**post.evidence, "speech_heard": heard.speech,
                                                       "instruction_heard": heard.speech and said})
        return post, said

    def _pending(self, online: OnlineInference, post: Posterior, decision: Decision, mode: str,
                 answered: tuple[Question, ...] = (), refused: tuple[str, ...] = (),
                 before: Pending | None = None) -> Pending | None:
        """What to keep while the robot waits on the answer to ``decision``'s question
        (``answered``, ``refused``: the exchange's questions answered and commands refused so far;
        ``before``: the record the reply answered, whose evidence the refused commands keep)."""
        from siftom.assist.reply import request_evidence

        q = decision.asked
        if q is None or mode == "speech-only":
            return None
        alone = self._view(online, "action-only", "phonetic").posterior(None, top=1)
        return Pending(q, request_evidence(post, alone, before, refused), str(post.command), answered, refused)

    def _reply(self, online: OnlineInference, pending: Pending, instruction: Instruction,
               call: _Call) -> Answer | None:
        """The answer to words that reply to ``pending`` (assist/reply.py); None when they answer
        nothing (more likely room talk than an answer, and no request: they are then an
        utterance like any other)."""
        mode, lk, why, top, decide, heard, t0, rel = (call.mode, call.likelihood, call.why, call.top, call.decide,
                                                      call.heard, call.t0, call.reliability)
        from siftom.assist.reply import (
            after_reply,
            heard_after,
            read_reply,
            refused_after,
            reply_texts,
        )

        name = lk if isinstance(lk, str) else type(lk).__name__
        view = self._view(online, mode, lk)
        words = with_likelihood(view.posterior(instruction, top=top), name, why)
        u = words.understanding
        # the objects of the world the reply asks for ("no, the sugar"); words naming nothing here
        # are not weighed as a reply (an utterance like any other says what they name)
        targets = tuple(m for m in u.targets if m.obj_class) \
            if u is not None and u.request and not words.evidence.get("no_instruction") else ()
        # the reply's own words: Whisper given the question before them (assist/reply.py, heard_after)
        after = heard_after(pending.question, instruction, view.model.likelihood)
        texts, weights = reply_texts(instruction, words, after)
        world, target = online.world, online.goals[0].target
        reading = read_reply(pending.question, texts, weights, world.classes, _lexicon_of(world))
        if not reading.answers and not targets:
            return None
        refused = refused_after(pending, reading, [m.obj_class for m in targets if m.obj_class])
        pending = dataclasses.replace(pending, refused=refused)
        base = words if targets else self._view(online, "action-only", "phonetic").posterior(None, top=top)
        answered = (*pending.answered, pending.question)
        assert base.joint is not None  # not speech-only: _reply runs for the other modes
        left = [c for c in base.joint.commands if str(c) not in set(refused)]
        post = after_reply(base, pending, reading, reliability_for(rel, pending.question.kind)) if left else base
        post = dataclasses.replace(post, transcript=instruction.text, understanding=u, evidence={
            **words.evidence, "reply_to": pending.question.text, "reply_cell": reading.cell,
            "reply": reading.to_json()})
        if left:
            decision = self.decide(post, world, target, decide, answer_reliability=rel, answered=answered)
        else:
            decision = self.decide(post, world, target, decide, nothing="every object here was refused")
        parts: tuple[RobotCommand, ...] = (post.command,) if left else ()
        if targets and left:  # the object asked for: the first target that names one ("none of those, the X")
            said = next((m for m in targets if m.obj_class or m.named), targets[0])
            decision, parts = said_object(decision, parts, said, post, world, target, online.verb)
        decision = dataclasses.replace(decision, reason=f"reply to {pending.question.text!r}: {decision.reason}")
        post = dataclasses.replace(post, decision=decision,
                                   evidence={**post.evidence, "parts": [str(c) for c in parts]})
        keep = self._pending(online, post, decision, mode, answered, refused, pending) \
            if decision.action == "ask" else None
        timings = {**(heard.timings if heard is not None else {}), "infer": time.perf_counter() - t0}
        return Answer(post, decision, None if heard is None else heard.speech,
                      heard.asr if heard is not None else None, heard.vad if heard is not None else None,
                      time.perf_counter() - t0, timings, True, parts, (), keep)

    def _decide_part(self, post: Posterior, world: World, target: int, rule: str | DecisionRule | None,
                     mention: Mention, rel: float | Mapping[str, float], verb: str) -> tuple[Decision, RobotCommand]:
        """The rule's decision on one part of a request with several, on its own slot: an absent
        object, or one of which nothing is left to bring, is declined with its reason."""
        made = self.decide(post, world, target, rule, answer_reliability=rel)
        decision, parts = said_object(made, (post.command,), mention, post, world, target, verb)
        return decision, parts[0] if parts else post.command

    def decide(self, post: Posterior, world: World, target: int, rule: str | DecisionRule | None = None,
               nothing: str = "", answer_reliability: float | Mapping[str, float] | None = None,
               answered: tuple[Question, ...] = ()) -> Decision:
        """The decision rule's answer (default: the setting ``infer.decide``); ``nothing``: why
        the robot was not asked anything (it then does nothing, whatever the rule);
        ``answer_reliability``: see :meth:`answer`; ``answered``: questions already answered
        about this request (not asked again)."""
        rule = rule if rule is not None else (self.settings.infer.decide or "map")
        name = rule if isinstance(rule, str) else getattr(rule, "name", type(rule).__name__)
        if nothing:
            reason = nothing + (f" ({post.evidence['no_instruction_reason']})"
                                if nothing == NO_INSTRUCTION and post.evidence.get("no_instruction_reason") else "")
            silent = Decision(name, NONE, NONE, 0.0, 0.0, reason=reason)
            if nothing != NO_INSTRUCTION or name != "teammate":
                return silent
            # words that may have asked: silence costs a person who asked more than a question
            # costs one who did not (assist/decide.py, ask_if_unsure)
            return ask_if_unsure(silent, _p_request(post), answered)
        made = get_rule(rule, **self.settings.rule_options(rule)) if isinstance(rule, str) else rule
        if post.joint is None or post.joint.state is None:  # speech-only: no state to value actions in
            mapped = MapRule()(post, None)
            if getattr(made, "confirms", False) and mapped.action not in ("ask", NONE) and not answered:
                # a rule that confirms before acting (a degraded answer's) asks here too
                from siftom.assist.asking import lexicon_of
                from siftom.assist.questions import confirm_question

                q = confirm_question(mapped.action, lexicon_of(world))
                return dataclasses.replace(mapped, rule=name, action="ask", question=q.text, options=q.options,
                                           question_kind=q.kind, asked=q, reason=f"confirms first: {mapped.reason}")
            return mapped
        rel = REPLY_RELIABILITY if answer_reliability is None else answer_reliability
        return made(post, Situation(world, post.joint.state, target, rel, answered=answered))

    def _view(self, online: OnlineInference, mode: str, likelihood: LikelihoodArg) -> OnlineInference:
        """``online`` scored by another model: a shallow copy (posterior() only reads the action state)."""
        model = self.model(mode, likelihood, _lexicon_of(online.world))
        if online.model is model:
            return online
        view = copy.copy(online)
        view.model = model
        return view

    # ----- one call ---------------------------------------------------------------------------
    def infer(self, scene: Any, actions: Any = None, heard: Any = None, *, likelihood: LikelihoodArg | None = None,
              decide: str | DecisionRule | None = None, mode: str | None = None, top: int | None = None,
              engine: str | None = None, nbest: int | None = None, gate: bool = True,
              pending: Pending | None = None) -> Answer:
        """What the robot does, from a scene, the person's actions and what was heard.

        Args:
            scene: a scenario id, a world or VirtualHome file, a loaded scene or a ``SceneInput``.
            actions: siftom or VirtualHome action lines, a file of them, or None (the scenario's own).
            heard: a transcript, an N-best list, an audio path or 16 kHz samples; None: nothing was said.
            likelihood, decide, mode, top, engine, nbest: left out, the settings.
            gate, pending: see :meth:`answer`.
        """
        from siftom.inputs import as_heard, resolve_scene

        t0 = time.perf_counter()
        sc = scene if isinstance(scene, SceneInput) else resolve_scene(scene, actions)
        return self._infer(sc, as_heard(heard), t0, likelihood=likelihood, decide=decide, mode=mode, top=top,
                           engine=engine, nbest=nbest, gate=gate, pending=pending)

    def listen(self, audio: str | Path | np.ndarray, scene: Any, actions: Any = None, *,
               likelihood: LikelihoodArg | None = None, decide: str | DecisionRule | None = None,
               mode: str | None = None, top: int | None = None, engine: str | None = None,
               nbest: int | None = None) -> Answer:
        """:meth:`infer` from a recording (a path or samples)."""
        from siftom.inputs import resolve_scene
        from siftom.speech.audio import as_audio

        t0 = time.perf_counter()
        sc = scene if isinstance(scene, SceneInput) else resolve_scene(scene, actions)
        x = as_audio(audio)
        load = time.perf_counter() - t0
        got = self._infer(sc, x, t0, likelihood=likelihood, decide=decide, mode=mode, top=top, engine=engine,
                          nbest=nbest)
        return dataclasses.replace(got, timings={"load": load, **got.timings})

    def _infer(self, sc: SceneInput, got: Instruction | np.ndarray | None, t0: float, *,
               likelihood: LikelihoodArg | None, decide: str | DecisionRule | None, mode: str | None,
               top: int | None, engine: str | None, nbest: int | None, gate: bool = True,
               pending: Pending | None = None) -> Answer:
        mode = mode or self.settings.model.mode
        if got is None and mode == "speech-only":
            raise ObservationError("speech-only inference needs heard= (a transcript, an N-best list or audio)")
        heard = None
        if isinstance(got, np.ndarray):
            heard = self.hear(got, sc.world, sc.verb, engine=engine, nbest=nbest)
            instruction = heard.instruction
        else:
            instruction = got
        online = self.online(sc, mode)
        ans = self.answer(online, instruction, likelihood=likelihood, decide=decide, top=top, heard=heard, mode=mode,
                          gate=gate, pending=pending)
        return dataclasses.replace(ans, seconds=time.perf_counter() - t0)

    def describe(self) -> dict[str, Any]:
        """The resolved values this observer runs with (``/healthz``, ``siftom config show``)."""
        return {key: value for key, value, _ in self.settings.show()}


def _p_request(post: Posterior) -> float:
    """P(somebody asked) the utterance model gave the words of ``post`` (0 when none)."""
    u = post.understanding
    if u is not None:
        return float(u.p_request)
    got = post.evidence.get("understanding")
    return float(got.get("p_request", 0.0)) if isinstance(got, Mapping) else 0.0


class _Locked:
    """A recogniser seen as an engine (``transcribe(samples, nbest=)``), one utterance at a time."""

    def __init__(self, rec: Recogniser) -> None:
        self.rec = rec

    def transcribe(self, samples: np.ndarray, nbest: int = 10) -> Any:
        return self.rec.transcribe(samples, nbest)


_DEFAULT: dict[Any, Observer] = {}
_DEFAULT_LOCK = threading.Lock()


def observer_for(settings: Settings | None = None) -> Observer:
    """The shared observer for ``settings`` (default: :meth:`Settings.load`), so one-shot calls
    (``siftom.infer``, ``siftom.listen``) with the same settings reuse its models and caches."""
    st = settings if settings is not None else Settings.load()
    key = _settings_key(st)
    with _DEFAULT_LOCK:
        got = _DEFAULT.get(key)
        if got is None:
            if len(_DEFAULT) >= 8:
                _DEFAULT.pop(next(iter(_DEFAULT)))
            got = _DEFAULT[key] = Observer(st)
        return got


def _settings_key(st: Settings) -> Any:
    def freeze(v: Any) -> Any:
        if isinstance(v, dict):
            return tuple(sorted((k, freeze(x)) for k, x in v.items()))
        if isinstance(v, (list, tuple)):
            return tuple(freeze(x) for x in v)
        try:
            hash(v)
        except TypeError:
            return repr(v)
        return v

    try:
        llm = st.llm
    except Exception:  # an invalid LLM environment: it fails when the llm likelihood is used
        llm = None
    return (freeze(dict(st.values)), freeze(dict(st.rules)), freeze(dict(st.likelihoods)), repr(llm))
