"""The server's CPU budget for answering utterances, shared by every stream and audio request.

Scoring an utterance with the acoustic likelihood (Whisper's transcript and its scores of the
candidate commands) costs about 3.5x the phonetic likelihood's CPU (``siftom bench latency``:
``cpu_ratio_p50`` 0.20 against 0.057). When more utterances are being answered at once than the
machine has cores, the next one would wait behind them, and on a small machine with several
robots the waits add up to seconds. :class:`Admission` counts the utterances in flight; one that
arrives while ``budget`` of them are already being answered is answered with the phonetic
likelihood instead, and its answer says so (``degraded``). Nothing is refused and no stream is
closed for load: a person who asked gets an answer, a little less sure, in time.

A degraded answer may lose confidence, never turn a decline or a question into an action: the
phonetic likelihood scores only what the recogniser, biased to the scene's own phrasings, heard,
so it cannot know what the full path (Whisper's open transcript) would have understood ("pass me
the cereal" where there is no cereal: the full path declines, the recogniser hears "the bowl").
Its decision rule is :class:`AskFirst`: where the rule would act, the robot asks the person to
confirm the command instead; a question or a decline stays as it is. A command the person's
answer named (yes to "Shall I get the bowl?") is carried out; one asked about and not confirmed
is not (the robot says so and waits for the request again).

The count is of the whole queue: an utterance whose speech has ended and that waits for the
recogniser or is being recognised (:meth:`Admission.recognising`) counts as much as one being
answered, and an utterance that joined the queue behind ``budget`` others counts them when its
turn comes, so in a burst (several robots hearing speech end at the same instant) every
utterance past the first ``budget`` is scored by the cheaper likelihood: the last of the burst
too, whose recognition waited behind all the others. And at most ``budget`` of these cheaper
answers compute at once; the next waits for a share (up to ``SHARE_WAIT_S``, then it runs
anyway), so the HTTP requests' threads keep a share of the interpreter while many streams are
answered.

The budget is the number of CPUs the process may use (``os.sched_getaffinity``), at least 1;
``Admission(budget=0)`` never degrades.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from siftom.assist.decision import Decision, DecisionRule, Situation
    from siftom.inference.model import Posterior
    from siftom.settings import Settings

DEGRADED_LIKELIHOOD = "phonetic"
# how long an answer waits for a CPU share before it runs anyway (a share is a priority, never a stall)
SHARE_WAIT_S = 0.5


def cpu_budget() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class Slot:
    """One utterance's admission: ``likelihood`` is None (the session's own) or the degraded one,
    and ``reason`` says why, in words an operator can read."""

    likelihood: str | None
    reason: str

    def rule(self, chosen: str | DecisionRule | None, settings: Settings) -> str | DecisionRule | None:
        """The decision rule for this utterance: ``chosen`` (None: the setting ``infer.decide``)
        as it is, or when degraded, :class:`AskFirst` around it (module doc)."""
        if self.likelihood is None:
            return chosen
        return AskFirst(chosen if chosen is not None else settings.infer.decide or "map", settings)


@dataclass(frozen=True)
class AskFirst:
    """A degraded answer's decision rule: ``base``'s decision, except that an action the person did
    not confirm becomes a question confirming it ("Shall I get the bowl?"), or none when they were
    asked about it and did not confirm; a question or a decline is kept. ``settings`` give a
    named rule its options (as the observer's)."""

    base: str | DecisionRule
    settings: Any = dataclasses.field(compare=False, repr=False)
    confirms: bool = True  # the observer asks first with it where no rule values actions (speech-only)

    @property
    def name(self) -> str:
        """The rule's name in the answer (the base rule's)."""
        b = self.base
        return b if isinstance(b, str) else str(getattr(b, "name", type(b).__name__))

    def __call__(self, post: Posterior, where: Situation) -> Decision:
        from siftom.assist.asking import lexicon_of
        from siftom.assist.decide import get_rule
        from siftom.assist.questions import confirm_question
        from siftom.assist.teamvalue import NONE

        b = self.base
        made: Decision = (get_rule(b, **self.settings.rule_options(b)) if isinstance(b, str) else b)(post, where)
        if made.action in ("ask", NONE):
            return made
        last = where.answered[-1] if where.answered else None
        if last is not None and made.action in last.options \
                and post.evidence.get("reply_cell") == last.cell(made.action):
            return made  # the person's answer named this command: carry it out
        if any(made.action in q.options for q in where.answered):  # asked, and not confirmed: say so
            return dataclasses.replace(made, action=NONE, declined="tell me again what you need",
                                       reason=f"answered under load with the cheaper likelihood: {made.action} "
                                              f"was asked about and not confirmed, so the robot does not act")
        q = confirm_question(made.action, lexicon_of(where.world))
        return dataclasses.replace(made, action="ask", question=q.text, options=q.options, question_kind=q.kind,
                                   asked=q, reason=f"answered under load with the cheaper likelihood, so the "
                                                   f"robot confirms before acting: {made.reason}")


class Admission:
    """Counts utterances being recognised and answered; past ``budget`` of them at once, the next is
    degraded, and at most ``budget`` answers compute at once (module doc)."""

    def __init__(self, budget: int | None = None, share_wait_s: float = SHARE_WAIT_S) -> None:
        self.budget = cpu_budget() if budget is None else max(0, int(budget))
        self.share_wait_s = share_wait_s
        self._cond = threading.Condition()
        self.in_flight = 0  # utterances inside :meth:`slot`
        self.hearing = 0  # utterances inside :meth:`recognising`: their speech ended, not yet answered
        self.computing = 0  # answers holding one of the ``budget`` CPU shares
        self.answered = 0
        self.degraded = 0
        self._ahead = threading.local()  # per thread: the queue ahead of the utterance it recognised last

    @contextlib.contextmanager
    def recognising(self) -> Iterator[None]:
        """Count an utterance while it waits for the recogniser and is recognised: it is in the
        queue before its answer is, and the answers being admitted meanwhile see it. The queue
        ahead of it when it joined is kept for this thread's next :meth:`slot` (its answer): the
        last of a burst has waited behind the others even when the queue is empty by its turn."""
        with self._cond:
            self._ahead.n = self.hearing + self.in_flight
            self.hearing += 1
        try:
            yield
        finally:
            with self._cond:
                self.hearing -= 1

    @contextlib.contextmanager
    def slot(self, asked: str | None = None) -> Iterator[Slot]:
        """Hold a place while one utterance is answered; the slot says how to score it. ``asked``:
        the likelihood the request or session chose; only the default (None or ``auto``) gives way.
        A degraded answer then waits (at most ``share_wait_s``) for one of the ``budget`` CPU
        shares; one scored by the full path does not wait (it runs when few others do, and its
        audio model computes outside the interpreter's lock)."""
        ahead, self._ahead.n = getattr(self._ahead, "n", 0), 0
        with self._cond:
            busy, queued = self.in_flight, self.hearing
            crowded = self.budget > 0 and max(busy + queued, ahead) >= self.budget and asked in (None, "auto")
            self.in_flight += 1
            self.answered += 1
            self.degraded += crowded
            if crowded:  # the cheaper answers compute at most budget at once (module doc)
                deadline = time.monotonic() + self.share_wait_s
                while self.budget <= self.computing and (left := deadline - time.monotonic()) > 0:
                    self._cond.wait(left)
                self.computing += 1
        try:
            if crowded and ahead > busy + queued:
                yield Slot(DEGRADED_LIKELIHOOD, f"answered with the {DEGRADED_LIKELIHOOD} likelihood: {ahead} "
                                                f"utterances were ahead of it in the queue on {self.budget} CPUs")
            elif crowded:
                also = f" and {queued} more being recognised" if queued else ""
                yield Slot(DEGRADED_LIKELIHOOD, f"answered with the {DEGRADED_LIKELIHOOD} likelihood: {busy} "
                                                f"utterances were being answered{also} on {self.budget} CPUs")
            else:
                yield Slot(None, "")
        finally:
            with self._cond:
                self.in_flight -= 1
                if crowded:
                    self.computing -= 1
                    self._cond.notify()

    def stats(self) -> dict[str, int]:
        """For /healthz: the budget, utterances in flight (answered now) and being recognised,
        answered and degraded so far."""
        with self._cond:
            return {"budget": self.budget, "in_flight": self.in_flight, "recognising": self.hearing,
                    "answered": self.answered, "degraded": self.degraded}
