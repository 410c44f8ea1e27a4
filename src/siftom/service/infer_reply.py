"""The answer of ``POST /v1/infer`` as a record (:class:`InferReply`), made by the runtime in
this process or in an audio worker process."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from siftom.assist.clarify import Clarification
from siftom.assist.route import RobotPlan


@dataclass(frozen=True)
class InferReply:
    """The answer of ``POST /v1/infer``: the observer's answer (its JSON, at the request's ``top``),
    the N-best list it heard, the clarifying decision, the robot's plan and, for a recording,
    why the likelihood gave way under load (``degraded``: '' when it did not)."""

    scenario: str
    answer: dict[str, Any]
    nbest: tuple[tuple[str, float], ...]
    clarification: Clarification
    plan: RobotPlan | None
    degraded: str | None = None  # None: not a recording (no ``degraded`` field)

    def to_json(self) -> dict[str, Any]:
        body: dict[str, Any] = {"scenario": self.scenario, **self.answer}
        body["nbest"] = [{"text": text, "score": score} for text, score in self.nbest]
        body["clarification"] = self.clarification.to_json()
        body["plan"] = self.plan.to_json() if self.plan is not None else None
        if self.degraded is not None:
            body["degraded"] = self.degraded
        return body
