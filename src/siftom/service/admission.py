"""The server's CPU budget for answering utterances, shared by every stream and audio request.

Scoring an utterance with the acoustic likelihood (Whisper's transcript and its scores of the
candidate commands) costs about 3.5x the phonetic likelihood's CPU (``siftom bench latency``:
``cpu_ratio_p50`` 0.20 against 0.057). When more utterances are being answered at once than the
machine has cores, the next one would wait behind them, and on a small machine with several
robots the waits add up to seconds. :class:`Admission` counts the utterances in flight; one that
arrives while ``budget`` of them are already being answered is answered with the phonetic
likelihood instead, and its answer says so (``degraded``). Nothing is refused and no stream is
closed for load: a person who asked gets an answer, a little less sure, in time.

The budget is the number of CPUs the process may use (``os.sched_getaffinity``), at least 1;
``ServiceSettings.answer_budget`` overrides it (0: never degrade).
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass

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
