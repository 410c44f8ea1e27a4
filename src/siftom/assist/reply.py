"""A question the robot asked, and the person's reply to it: the loop closed (docs/decisions.md, "Replies").

When the robot asks, the caller that holds the conversation (a session, a stream, the ROS
bridge) keeps a :class:`Pending` record: the question, and what the request's words said about
each command -- their log-likelihood ratio against the actions alone,
``log P(c | words, actions) - log P(c | actions)``, which is ``log P(words | c)`` up to a
constant. The reply is a second utterance about the same command, independent of the first given
the command, so the posterior after it is exact Bayes on the actions observed by then:

    P(c | request, reply, actions) ∝ P(c | actions) · P(request | c) · P(reply | c)

A reply speaks to the question in two ways, which may both be there ("no, the sugar"):

* it names one of the question's cells with the words of its answer grammar ("yes", "the
  cereal", "three", "neither"), heard through the kind's measured channel
  (:func:`~siftom.assist.questions.answer_log_likelihood_cells`, reliability
  :data:`REPLY_RELIABILITY`);
* it asks for an object as a request does ("the sugar please"): the instruction likelihood on
  its words.

A reply that does neither (room talk, "hmm", a cough) answers nothing: it is an utterance like
any other, and the question stays pending.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from siftom.assist.decide import with_answer
from siftom.assist.questions import Question, answer_log_likelihood_cells, answer_reliability
from siftom.errors import ObservationError
from siftom.inference.model import JointPosterior, Posterior
from siftom.observation import Instruction

MAX_EVIDENCE = 64  # the commands whose evidence a pending question keeps (the rest: the weakest kept)
EVIDENCE_FLOOR = -50.0  # nats below the best: a command the request's words ruled out


def reply_reliability(kind: str) -> float:
    """The chance a reply to a ``kind`` question is heard as the cell it names: the measured
    clean value (the doors do not know the noise level of a conversation)."""
    return answer_reliability(None, kind) if kind in ("confirm", "choose", "count") else 1.0


REPLY_RELIABILITY = {k: reply_reliability(k) for k in ("confirm", "choose", "count")}


def log_marginals(joint: JointPosterior) -> dict[str, float]:
    """log P(c) per command of a joint posterior (unnormalised the same way for every command)."""
    lm = np.full(len(joint.commands), -np.inf)
    np.logaddexp.at(lm, joint.cmd_idx, joint.log_joint)
    return {str(c): float(v) for c, v in zip(joint.commands, lm, strict=True)}


def request_evidence(post: Posterior, alone: Posterior) -> tuple[tuple[str, float], ...]:
    """The log-likelihood ratio of what was heard per command, best first, the best at 0 (module doc):
    ``post``, the posterior with the words; ``alone``, the one from the same actions without them."""
    if post.joint is None or alone.joint is None:
        return ()
    with_words, without = log_marginals(post.joint), log_marginals(alone.joint)
    ratio = {c: v - without[c] for c, v in with_words.items() if c in without and np.isfinite(without[c])}
    finite = {c: v for c, v in ratio.items() if np.isfinite(v)}
    if not finite:
        return ()
    best = max(finite.values())
    ranked = sorted(((c, max(v - best, EVIDENCE_FLOOR)) for c, v in finite.items()), key=lambda cv: -cv[1])
    return tuple((c, round(v, 6)) for c, v in ranked[:MAX_EVIDENCE])


@dataclass(frozen=True)
class Pending:
    """A question the robot asked and waits on an answer to.

    Attributes:
        question: the question (its cells and answer grammar).
        evidence: per command, the log-likelihood ratio of the words that led to the question
            (best first, the best at 0); a command not listed gets the weakest listed value.
        asked: the command the robot took to be asked for.
        answered: the questions about this request answered before this one (not asked again).
    """

    question: Question
    evidence: tuple[tuple[str, float], ...]
    asked: str
    answered: tuple[Question, ...] = ()

    def log_lik(self, commands: Sequence[Any]) -> np.ndarray:
        """The request's evidence for each of ``commands``."""
        ev = dict(self.evidence)
        floor = min(ev.values(), default=0.0)
        return np.array([ev.get(str(c), floor) for c in commands], dtype=np.float64)

    def to_json(self) -> dict[str, Any]:
        return {"question": self.question.to_json(), "asked": self.asked,
                "evidence": [[c, v] for c, v in self.evidence], "answered": [q.to_json() for q in self.answered]}

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> Pending:
        try:
            ev = tuple((str(c), float(v)) for c, v in obj["evidence"])
            q = Question.from_json(obj["question"])
            asked = str(obj["asked"])
            answered = tuple(Question.from_json(a) for a in obj.get("answered", ()))
        except (KeyError, TypeError, ValueError) as exc:
            raise ObservationError(f"a pending question needs question, asked and evidence ({exc})") from None
        if not all(np.isfinite(v) for _c, v in ev):
            raise ObservationError("a pending question's evidence must be finite numbers")
        return cls(q, ev, asked, answered)


def cell_named(question: Question, instruction: Instruction) -> int | None:
    """The cell of ``question`` the reply names: the first hypothesis, best first, that names one."""
    texts = [h.text for h in instruction.nbest] or [instruction.text]
    for text in texts:
        cell = question.heard_cell(text)
        if cell is not None:
            return cell
    return None


def after_reply(base: Posterior, pending: Pending, cell: int | None, reliability: float | None = None) -> Posterior:
    """``base`` (the reply's words, or the actions alone) with the request's evidence and the
    named cell's added: the posterior after the exchange (module doc). ``reliability``: how often
    an answer to the question's kind is heard as the cell it names (None: :data:`REPLY_RELIABILITY`)."""
    if base.joint is None:
        raise ObservationError("a reply is weighed against a posterior with its hypotheses (not speech-only)")
    commands = [str(c) for c in base.joint.commands]
    ll = pending.log_lik(commands)
    if cell is not None:
        r = reply_reliability(pending.question.kind) if reliability is None else reliability
        ll = ll + answer_log_likelihood_cells(pending.question, commands, cell, r)
    return with_answer(base, ll)
