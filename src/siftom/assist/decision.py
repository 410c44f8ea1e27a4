"""What a decision rule decides (:class:`Decision`) and where (:class:`Situation`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from siftom.assist.questions import Question, reliability_for
from siftom.errors import ObservationError
from siftom.inference.model import JointPosterior, Posterior
from siftom.world.model import State, World

# The time of one spoken exchange when a caller fixes it (``ask_cost=``) and for the simple pair
# questions of question_values; ``ask-or-act`` prices each question by its words instead
# (assist/askcost.py: speaking rate, turn gaps, the robot's recognition; docs/decisions.md).
DEFAULT_ASK_COST = 2.0


@dataclass(frozen=True)
class Decision:
    """What the robot does.

    Attributes:
        rule: the rule's name.
        action: the command to execute, ``none`` (do nothing) or ``ask``.
        command: the command it executes when it does not ask (or before the answer).
        prob: posterior probability of ``command`` (0 for ``none``).
        expected_benefit: expected steps saved by ``command`` (nan for ``map`` without values).
        question: the spoken question when ``action == 'ask'``, else ''.
        options: the commands the question contrasts.
        evi: expected value of information of the best question, in steps (question_values).
        ask_cost: the cost of asking, in steps.
        reason: one line saying why.
        benefits: the best few actions with their expected benefit, best first.
        declined: when the robot turns a request down, what it says to the person ("the honey
            is already with you"); '' otherwise.
    """

    rule: str
    action: str
    command: str
    prob: float
    expected_benefit: float
    question: str = ""
    options: tuple[str, ...] = ()
    evi: float = 0.0
    ask_cost: float = DEFAULT_ASK_COST
    reason: str = ""
    benefits: tuple[tuple[str, float], ...] = field(default=(), compare=False)
    question_kind: str = ""
    asked: Question | None = field(default=None, compare=False)
    declined: str = ""

    @property
    def ask(self) -> bool:
        return self.action == "ask"

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        eb = self.expected_benefit
        return {"rule": self.rule, "action": self.action, "command": self.command, "prob": self.prob,
                "expected_benefit": None if not np.isfinite(eb) else round(eb, 4), "question": self.question,
                "options": list(self.options), "evi": round(self.evi, 4), "ask_cost": self.ask_cost,
                "reason": self.reason, "question_kind": self.question_kind, "declined": self.declined,
                "answers": list(self.asked.grammar()) if self.asked is not None else [],
                "benefits": [{"action": a, "expected_benefit": round(b, 4)} for a, b in self.benefits]}


@dataclass(frozen=True)
class Situation:
    """Where the decision is taken: the world, the state when the human spoke, the target."""

    world: World
    state: State
    target: int
    # probability that a spoken answer is heard as the cell it names (1: perfectly), one number
    # or one per question kind ({"confirm": 0.95, ...}); the noise is part of the situation
    # (docs/decisions.md)
    answer_reliability: float | Mapping[str, float] = 1.0
    # steps the human spent before speaking (part of L_single and L_team; only the speedup
    # utility depends on it)
    prefix: float = 0.0
    # the questions already answered about this request (a reply was weighed): neither they nor
    # a question only about their options is asked again ("How many bowls?" -- "four": not
    # "Shall I bring four bowls?")
    answered: tuple[Question, ...] = ()

    def settled(self, q: Question) -> bool:
        """Whether ``q`` asks again what an answered question asked (the same text, or options
        all among one answered question's options)."""
        return any(q.text == a.text or (q.options and set(q.options) <= set(a.options)) for a in self.answered)

    def __post_init__(self) -> None:
        r = self.answer_reliability
        for v in (r.values() if isinstance(r, Mapping) else (r,)):
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and 0.0 <= v <= 1.0):
                raise ObservationError(f"answer_reliability must be a probability in [0, 1] (or a mapping "
                                       f"question kind -> probability), got {r!r}")

    def reliability(self, kind: str) -> float:
        """How reliably an answer to a question of ``kind`` is heard here."""
        return reliability_for(self.answer_reliability, kind)

    @classmethod
    def from_scenario(cls, scenario: Any, n_actions: int | None = None,
                      answer_reliability: float | Mapping[str, float] = 1.0) -> Situation:
        from siftom.world.model import cost

        states = scenario.states()
        k = len(scenario.actions) if n_actions is None else n_actions
        prefix = float(sum(cost(scenario.world, s, a) for s, a in zip(states[:k], scenario.actions[:k], strict=True)))
        return cls(scenario.world, states[k], scenario.target, answer_reliability, prefix)


DecisionRule = Callable[[Posterior, Situation], Decision]


def joint_of(post: Posterior) -> JointPosterior:
    if post.joint is None:
        raise ObservationError("this posterior carries no hypotheses; decision rules other than 'map' need one "
                               "from SIFToM.infer (siftom.inference)")
    return post.joint

