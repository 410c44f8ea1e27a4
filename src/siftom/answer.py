"""The one answer shape every door returns: what the robot does, beside the posterior.

An :class:`Answer` is what :meth:`siftom.Observer.infer` and :meth:`siftom.Observer.listen`
return (and so ``siftom.infer``, ``siftom.listen``, ``siftom infer``, ``POST /v1/infer``, a
session's instruction, the streaming endpoint's ``decision`` event and the ROS bridge):

* ``action``: ``act`` (carry out ``command``), ``ask`` (ask ``decision.question`` first) or
  ``none`` (do nothing; ``decision.reason`` says why: no speech heard, no instruction heard, or
  no command worth its risk);
* ``command``: the command the robot carries out, or None when it does not act;
* ``top_command``: the posterior's most probable command, for analysis (the paper's inferred
  command), whatever the robot does;
* the posterior (``commands``, ``goals``, ``hypotheses``, ``evidence``) and, from audio, what was
  heard (``speech_heard``, ``asr``, ``vad``);
* who heard it and what decided: ``recogniser`` (the speech recogniser that turned the audio into
  words, e.g. ``pocketsphinx-vocab``; None when words were given), ``likelihood`` (the instruction
  likelihood that scored them, e.g. ``acoustic``) and ``rule`` (the decision rule that ran).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from siftom.assist.decide import Decision
from siftom.assist.reply import Pending
from siftom.inference.listen import NO_INSTRUCTION, NO_SPEECH
from siftom.inference.model import JointHypothesis, JointPosterior, Posterior
from siftom.language.record import NOBODY_ASKED, Understanding
from siftom.world.commands import RobotCommand

ACTIONS = ("act", "ask", "none")
NOTHING_ASKED = "nothing was asked"


@dataclass(frozen=True)
class Answer:
    """What the robot does and why, beside the posterior it came from.

    Attributes:
        posterior: the posterior (from the actions alone when no speech or no instruction was heard).
        decision: what the decision rule made of it (``Decision``: rule, action, reason, question).
        speech: from audio, whether speech was detected; None when words were given.
        asr: the recogniser's output for audio (a ``Transcript``), None otherwise.
        vad: the voice-activity detector's result for audio, None otherwise.
        seconds: wall time from the input to the answer.
        timings: seconds per stage (load, vad, asr, infer).
        instruction: False when words were heard but nobody asked the robot for anything
            (``evidence['no_instruction_reason']`` says why).
        parts: the command understood for each object asked for, in the order said (one for a
            plain request, several for "the cereal and the sugar", none when nobody asked).
        part_decisions: for a request of several parts, the rule's decision on each.
        pending: the question the robot waits on an answer to after this one (its own, or one
            still open when these words asked nothing); pass it to the next
            :meth:`~siftom.Observer.answer` of the conversation.
    """

    posterior: Posterior
    decision: Decision
    speech: bool | None = None
    asr: Any = None
    vad: Any = None
    seconds: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    instruction: bool = True
    parts: tuple[RobotCommand, ...] = ()
    part_decisions: tuple[Decision, ...] = field(default=(), compare=False)
    pending: Pending | None = field(default=None, compare=False)

    # ----- what the robot does --------------------------------------------------------------
    @property
    def action(self) -> str:
        """``act``, ``ask`` or ``none``."""
        a = self.decision.action
        return a if a in ("ask", "none") else "act"

    @property
    def command(self) -> RobotCommand | None:
        """The command the robot carries out; None when it asks or does nothing."""
        if self.action != "act":
            return None
        return RobotCommand.parse(self.decision.command)

    @property
    def carry_out(self) -> tuple[RobotCommand, ...]:
        """Every command the robot carries out, in order (several for a request of several parts)."""
        if self.action != "act":
            return ()
        if self.part_decisions:
            return tuple(RobotCommand.parse(d.command) for d in self.part_decisions if d.action not in ("none", "ask"))
        cmd = self.command
        return (cmd,) if cmd is not None else ()

    @property
    def understanding(self) -> Understanding:
        """What the utterance model understood of the words (``NOBODY_ASKED`` when nothing was said)."""
        return self.posterior.understanding or NOBODY_ASKED

    @property
    def reply_to(self) -> str | None:
        """The question these words answered (they were weighed with the request that led to it)."""
        got = self.posterior.evidence.get("reply_to")
        return str(got) if got else None

    @property
    def top_command(self) -> RobotCommand:
        """The posterior's most probable command (for analysis; the robot may not act on it)."""
        return self.posterior.command

    @property
    def message(self) -> str:
        """"no speech heard", "no instruction heard" or ''."""
        if self.speech is False:
            return NO_SPEECH
        return "" if self.instruction else NO_INSTRUCTION

    @property
    def doing(self) -> str:
        """What the robot does, in a few words: "fetch(cereal)", "asks: ..." or "nothing (...)"."""
        if self.action == "act":
            return ", ".join(str(c) for c in self.carry_out)
        if self.action == "ask":
            return f"asks: {self.decision.question}"
        return f"nothing ({self.message or self.decision.declined or self.decision.reason})"

    @property
    def speech_heard(self) -> bool:
        """False only when a recording held no speech."""
        return self.speech is not False

    @property
    def instruction_heard(self) -> bool:
        """Whether words near a command of the scene were heard."""
        return self.speech_heard and self.instruction

    # ----- the posterior, read through -------------------------------------------------------
    @property
    def commands(self) -> tuple[tuple[RobotCommand, float], ...]:
        return self.posterior.commands

    @property
    def goals(self) -> tuple[tuple[str, float], ...]:
        return self.posterior.goals

    @property
    def hypotheses(self) -> tuple[JointHypothesis, ...]:
        return self.posterior.hypotheses

    @property
    def evidence(self) -> dict[str, Any]:
        return self.posterior.evidence

    @property
    def joint(self) -> JointPosterior | None:
        return self.posterior.joint

    @property
    def transcript(self) -> str:
        """The words the posterior was given (the best hypothesis), '' for none."""
        return self.posterior.transcript

    @property
    def likelihood(self) -> str:
        """The instruction likelihood that scored what was heard (``phonetic``, ``acoustic``, ...)."""
        return self.posterior.likelihood

    @property
    def recogniser(self) -> str | None:
        """The speech recogniser that heard the audio (the ASR engine's name, e.g.
        ``pocketsphinx-vocab``); None when words were given rather than heard."""
        engine = getattr(self.asr, "engine", None)
        return str(engine) if engine else None

    @property
    def rule(self) -> str:
        """The decision rule that ran (``expected-benefit``, ``ask-or-act``, ``map``)."""
        return self.decision.rule

    @property
    def mode(self) -> str:
        return self.posterior.mode

    @property
    def n_actions(self) -> int:
        return self.posterior.n_actions

    def prob(self, command: str) -> float:
        """The posterior probability of ``command``."""
        return self.posterior.prob(command)

    @property
    def top_prob(self) -> float:
        """P(top_command)."""
        return float(self.posterior.commands[0][1]) if self.posterior.commands else 0.0

    def to_json(self, top: int = 10) -> dict[str, Any]:
        """The documented JSON shape (docs/api.md): the posterior's fields, then ``command``
        (null unless the robot acts), ``action``, ``top_command``, ``decision``, what was heard and
        who heard it (``recogniser``, ``likelihood``, ``rule``)."""
        out = self.posterior.to_json(top=top)
        cmd = self.command
        out.update({
            "command": str(cmd) if cmd is not None else None,
            "action": self.action,
            "top_command": str(self.top_command),
            "top_prob": self.top_prob,
            "decision": self.decision.to_json(),
            "rule": self.rule,
            "recogniser": self.recogniser,
            "speech_heard": self.speech_heard,
            "instruction_heard": self.instruction_heard,
            "message": self.message,
            "understanding": self.understanding.to_json(),
            "parts": [str(c) for c in self.parts],
            "carry_out": [str(c) for c in self.carry_out],
            "reply_to": self.reply_to,
            "awaiting_reply": self.pending is not None,
            "asr": self.asr.to_json() if self.asr is not None else None,
            "vad": self.vad.to_json() if self.vad is not None else None,
            "seconds": round(self.seconds, 4),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        })
        return out
