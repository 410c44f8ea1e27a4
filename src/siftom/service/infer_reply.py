"""One ``POST /v1/infer`` call as a record (:class:`InferCall`), from the router to the runtime,
the audio worker processes and the observer, and its answer (:class:`InferReply`), made by the
runtime in this process or in an audio worker process."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from siftom.assist.clarify import Clarification, ClarifyPolicy
from siftom.assist.route import RobotPlan

if TYPE_CHECKING:
    from siftom.assist.decision import DecisionRule
    from siftom.observation import Instruction
    from siftom.observer import Heard


@dataclass(frozen=True)
class InferCall:
    """What one inference request asks, validated (the JSON and the multipart forms alike).

    Attributes:
        scenario: a registered scenario id.
        instruction: the words heard (a transcript or an N-best list); None: nothing was said,
            or a recording still to be recognised.
        audio: the uploaded recording (the multipart form), None for words; once recognised,
            ``heard`` and ``instruction`` say what was heard in it.
        heard: the clip the instruction was recognised from.
        mode: full SIFToM or an ablation (None: the model's setting).
        likelihood: the instruction likelihood (None: the setting ``infer.likelihood``).
        rule: the decision rule, a name or a rule (None: the setting ``infer.decide``).
        n_actions: the scenario's first n observed actions (None: all).
        actions: the person's actions instead of the scenario's.
        top: commands, goals and hypotheses returned (None: ``infer.top``).
        asr_nbest: hypotheses asked of the recogniser (None: ``infer.nbest``).
        policy: when the clarification asks.
    """

    scenario: str
    instruction: Instruction | None = None
    audio: bytes | None = dataclasses.field(default=None, repr=False)
    heard: Heard | None = None
    mode: str | None = None
    likelihood: str | None = None
    rule: str | DecisionRule | None = None
    n_actions: int | None = None
    actions: tuple[str, ...] | None = None
    top: int | None = None
    asr_nbest: int | None = None
    policy: ClarifyPolicy = dataclasses.field(default_factory=ClarifyPolicy)

    def with_(self, **changes: Any) -> InferCall:
        """This call with some fields changed (what was heard, the likelihood under load)."""
        return dataclasses.replace(self, **changes)


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
