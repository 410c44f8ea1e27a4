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

**An answer or not is a hypothesis.** Whether the words answer the open question is weighed,
not keyword-gated (:func:`read_reply`): each hypothesis of what was heard (the recogniser's
N-best with its weights, or Whisper's words when it heard some) is read by the utterance model
(``siftom.language.parse.read``: slots with their roles, negation included) against the
question's cells, and two stories compete for its words -- *an answer* (short, made of the
question's answer words, object names and function words, naming a cell) and *room talk*
(anything else, which names a cell only by chance). Each cue is a likelihood ratio
P(cue | answer) / P(cue | room talk) (:data:`P_CELL`, :data:`P_EXTRA`); P(answer | words) averages
over the hypotheses. The reply's factor per command is the mixture of the two stories,

    P(reply | c) ∝ sum_n w_n [a_n P(cells_n | c) / P(cells_n) + (1 - a_n)],

``a_n`` = P(answer | hypothesis n), ``cells_n`` the cells its words allow ("not the cheese": every
cell but the cheese's), heard through the kind's channel. Words more likely room talk than an
answer (and asking for nothing) answer nothing: the question stays pending.

**A refused option stays refused.** An option the reply refuses ("not the cheese", "neither",
"no" to "Shall I get the cereal?") with probability over one half loses its mass for good in
that exchange (:attr:`Pending.refused`): it is neither offered in a later question nor carried
out, unless a later reply asks for it by name.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from siftom.assist.decide import with_answer
from siftom.assist.questions import Question, answer_log_likelihood_cells, answer_reliability
from siftom.assist.reply_reading import (
    ANSWER_KINDS,
    P_CELL,
    P_EXTRA,
    PRIOR_ANSWER,
    REFUSAL_OTHER,
    HeardAnswer,
    ReplyReading,
    _parse_command,
    cell_named,
    heard_after,
    read_answer,
    read_reply,
    reply_texts,
)
from siftom.errors import ObservationError
from siftom.inference.model import JointPosterior, Posterior

__all__ = [
    "ANSWER_KINDS", "EVIDENCE_FLOOR", "MAX_EVIDENCE", "P_CELL", "P_EXTRA", "PRIOR_ANSWER", "REFUSAL_OTHER", "REFUSED",
    "REPLY_RELIABILITY", "HeardAnswer", "Pending", "ReplyReading", "after_reply", "cell_named", "heard_after",
    "log_marginals", "read_answer", "read_reply", "refused_after", "reply_reliability", "reply_texts",
    "request_evidence",
]

MAX_EVIDENCE = 64  # the commands whose evidence a pending question keeps (the rest: the weakest kept)
EVIDENCE_FLOOR = -50.0  # nats below the best: a command the request's words ruled out
# log-likelihood of a refused command: finite (an update takes finite scores), and its
# probability is exactly 0 in double precision next to any command not refused
REFUSED = -1.0e4


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


def request_evidence(post: Posterior, alone: Posterior, before: Pending | None = None,
                     refused: Sequence[str] = ()) -> tuple[tuple[str, float], ...]:
    """The log-likelihood ratio of what was heard per command, best first, the best at 0 (module doc):
    ``post``, the posterior with the words; ``alone``, the one from the same actions without them.
    A command ``refused`` in the exchange keeps the evidence ``before`` (the record the reply
    answered) gave it: its probability is 0 while refused, and should the person ask for it
    again by name, the request's words for it are as they were."""
    if post.joint is None or alone.joint is None:
        return ()
    with_words, without = log_marginals(post.joint), log_marginals(alone.joint)
    ratio = {c: v - without[c] for c, v in with_words.items() if c in without and np.isfinite(without[c])}
    out = set(refused)
    finite = {c: v for c, v in ratio.items() if np.isfinite(v) and c not in out}
    if not finite:
        return ()
    best = max(finite.values())
    ranked = sorted(((c, max(v - best, EVIDENCE_FLOOR)) for c, v in finite.items()), key=lambda cv: -cv[1])
    kept = ranked[:MAX_EVIDENCE]
    if before is not None and out:
        ev, floor = dict(before.evidence), min((v for _c, v in before.evidence), default=0.0)
        kept = sorted(kept + [(c, ev.get(c, floor)) for c in out], key=lambda cv: -cv[1])
    return tuple((c, round(v, 6)) for c, v in kept)


@dataclass(frozen=True)
class Pending:
    """A question the robot asked and waits on an answer to.

    Attributes:
        question: the question (its cells and answer grammar).
        evidence: per command, the log-likelihood ratio of the words that led to the question
            (best first, the best at 0); a command not listed gets the weakest listed value.
        asked: the command the robot took to be asked for.
        answered: the questions about this request answered before this one (not asked again).
        refused: the commands the person refused in this exchange ("not the cheese",
            "neither"): their probability is 0 from then on (module doc).
    """

    question: Question
    evidence: tuple[tuple[str, float], ...]
    asked: str
    answered: tuple[Question, ...] = ()
    refused: tuple[str, ...] = ()

    def log_lik(self, commands: Sequence[Any]) -> np.ndarray:
        """The request's evidence for each of ``commands`` (a refused one: :data:`REFUSED`)."""
        ev = dict(self.evidence)
        floor = min(ev.values(), default=0.0)
        refused = set(self.refused)
        return np.array([REFUSED if str(c) in refused else ev.get(str(c), floor) for c in commands],
                        dtype=np.float64)

    def to_json(self) -> dict[str, Any]:
        return {"question": self.question.to_json(), "asked": self.asked,
                "evidence": [[c, v] for c, v in self.evidence], "answered": [q.to_json() for q in self.answered],
                "refused": list(self.refused)}

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> Pending:
        """The record :meth:`to_json` wrote (one without ``answered`` or ``refused``, as older
        versions wrote, reads as none)."""
        try:
            ev = tuple((str(c), float(v)) for c, v in obj["evidence"])
            q = Question.from_json(obj["question"])
            asked = str(obj["asked"])
            answered = tuple(Question.from_json(a) for a in obj.get("answered", ()))
            refused = obj.get("refused", ())
            if isinstance(refused, str) or not all(isinstance(c, str) for c in refused):
                raise TypeError("refused must be a list of commands")
            refused = tuple(refused)
        except (KeyError, TypeError, ValueError) as exc:
            raise ObservationError(f"a pending question needs question, asked and evidence ({exc})") from None
        if not all(np.isfinite(v) for _c, v in ev):
            raise ObservationError("a pending question's evidence must be finite numbers")
        return cls(q, ev, asked, answered, refused)


def refused_after(pending: Pending, reading: ReplyReading, asked: Sequence[str] = ()) -> tuple[str, ...]:
    """The commands refused in the exchange after this reply: those refused before and those it
    refuses, less any of a class the reply asks for by name (``asked``: the classes of its
    request's targets, unless this reply refuses them -- its request may have been read from
    other words; the options it names count too)."""
    now = {p.obj_class for o in reading.refused if (p := _parse_command(o)) is not None}
    again = (set(asked) - now) | {p.obj_class for o in reading.named if (p := _parse_command(o)) is not None}
    return tuple(str(c) for c in dict.fromkeys((*pending.refused, *reading.refused))
                 if (p := _parse_command(c)) is None or p.obj_class not in again)


def _marginals(post: Posterior) -> np.ndarray:
    """P(c) per ``post.joint.commands``."""
    assert post.joint is not None
    lm = np.full(len(post.joint.commands), -np.inf)
    np.logaddexp.at(lm, post.joint.cmd_idx, post.joint.log_joint)
    p: np.ndarray = np.exp(lm - lm.max())
    p /= p.sum()
    return p


def after_reply(base: Posterior, pending: Pending, cell: int | ReplyReading | None,
                reliability: float | None = None) -> Posterior:
    """``base`` (the reply's words, or the actions alone) with the request's evidence and the
    reply's added: the posterior after the exchange (module doc). ``cell``: the reply's reading
    (:func:`read_reply`), or the one cell it names as heard for certain (None: no cell).
    ``reliability``: how often an answer to the question's kind is heard as the cell it names
    (None: :data:`REPLY_RELIABILITY`). The pending record's refused commands get probability 0.

    What the words say of each command (``joint.log_words``, which the decision reads) is what
    the whole exchange said: the request's evidence and the reply's, beside the reply's own
    instruction term when ``base`` has one."""
    import dataclasses

    if base.joint is None:
        raise ObservationError("a reply is weighed against a posterior with its hypotheses (not speech-only)")
    commands = [str(c) for c in base.joint.commands]
    ll = pending.log_lik(commands)
    r = reply_reliability(pending.question.kind) if reliability is None else reliability
    if isinstance(cell, ReplyReading):
        prior = _marginals(with_answer(base, ll))
        ll = ll + cell.log_lik(commands, prior, r)
    elif cell is not None:
        ll = ll + answer_log_likelihood_cells(pending.question, commands, cell, r)
    post = with_answer(base, ll)
    own = base.joint.log_words
    said = ll + (np.asarray(own, dtype=np.float64) if own is not None and np.shape(own) == ll.shape else 0.0)
    assert post.joint is not None
    return dataclasses.replace(post, joint=dataclasses.replace(post.joint, log_words=said))
