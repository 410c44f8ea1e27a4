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

The budget is the number of CPUs the process may use (``os.sched_getaffinity``), at least 1;
``ServiceSettings.answer_budget`` overrides it (0: never degrade).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from siftom.assist.decision import Decision, DecisionRule, Situation
    from siftom.inference.model import Posterior
    from siftom.settings import Settings

DEGRADED_LIKELIHOOD = "phonetic"


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
    """Counts utterances being answered; past ``budget`` at once, the next is degraded (module doc)."""

    def __init__(self, budget: int | None = None) -> None:
        self.budget = cpu_budget() if budget is None else max(0, int(budget))
        self._lock = threading.Lock()
        self.in_flight = 0
        self.answered = 0
        self.degraded = 0

    @contextlib.contextmanager
    def slot(self, asked: str | None = None) -> Iterator[Slot]:
        """Hold a place while one utterance is answered; the slot says how to score it. ``asked``:
        the likelihood the request or session chose; only the default (None or ``auto``) gives way."""
        with self._lock:
            busy = self.in_flight
            crowded = self.budget > 0 and busy >= self.budget and asked in (None, "auto")
            self.in_flight += 1
            self.answered += 1
            self.degraded += crowded
        try:
            if crowded:
                yield Slot(DEGRADED_LIKELIHOOD, f"answered with the {DEGRADED_LIKELIHOOD} likelihood: {busy} "
                                                f"utterances were being answered on {self.budget} CPUs")
            else:
                yield Slot(None, "")
        finally:
            with self._lock:
                self.in_flight -= 1

    def stats(self) -> dict[str, int]:
        """For /healthz: the budget, utterances in flight, answered and degraded so far."""
        with self._lock:
            return {"budget": self.budget, "in_flight": self.in_flight, "answered": self.answered,
                    "degraded": self.degraded}
