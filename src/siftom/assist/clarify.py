"""Act or ask: a clarifying question chosen by expected value of information (EVI).

The robot's utility is 1 when it carries out the command the person meant and 0 otherwise,
so acting now on the MAP command is worth ``p1`` (its posterior probability). Asking the
binary question "A or B?" (answers: A, B, or "neither") is worth

    EU(ask A|B) = p_A + p_B + max_{c not in {A, B}} p_c

because the answer reveals the command when it is A or B, and "neither" leaves the best of
the rest (renormalised, the same expected success). Over all pairs this is largest for the
two most probable commands, so

    EVI = EU(ask top-2) - EU(act) = p2 + p3.

The robot asks when the posterior is too flat to act, ``p1 < threshold``, and the question
is worth its cost, ``EVI > cost`` (cost in the same units: the chance of success one
question is worth giving up for the person's time). docs/service.md documents the rule.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

from siftom.errors import ObservationError

DEFAULT_THRESHOLD = 0.6
DEFAULT_COST = 0.1


@dataclass(frozen=True)
class ClarifyPolicy:
    """When to ask: MAP probability below ``threshold`` and EVI above ``cost`` (both in [0, 1])."""

    threshold: float = DEFAULT_THRESHOLD
    cost: float = DEFAULT_COST

    def __post_init__(self) -> None:
        for name in ("threshold", "cost"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ObservationError(f"{name} must be within 0..1 (a probability), got {v}")


@dataclass(frozen=True)
class Clarification:
    """The decision: act on ``command`` or ask ``question`` to choose between ``options``.

    Attributes:
        ask: whether the robot should ask before acting.
        command: the MAP command (what the robot does if it does not ask).
        question: the spoken question when ``ask``, else ''.
        options: the two commands the question contrasts (the top two).
        p_map: posterior probability of the MAP command.
        evi: expected value of information of asking (p2 + p3).
        threshold: the policy's MAP threshold.
        cost: the policy's cost of asking.
        reason: one line saying why the robot acts or asks.
    """

    ask: bool
    command: str
    question: str
    options: tuple[str, ...]
    p_map: float
    evi: float
    threshold: float
    cost: float
    reason: str

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        d = asdict(self)
        d["options"] = list(self.options)
        return d


def expected_value_of_asking(probs: Sequence[float]) -> float:
    """EVI of asking "first or second?" given command probabilities sorted best first."""
    p = sorted((float(x) for x in probs), reverse=True)
    return sum(p[1:3])


def describe_command(command: str) -> str:
    """Spoken noun phrase for a command (the one phrase maker, :func:`siftom.assist.questions.describe`):
    ``fetch(cereal)`` -> "the cereal", ``deliver(waterglass,3)`` -> "three water glasses"."""
    from siftom.assist.questions import describe

    return describe(command)


def clarify(commands: Sequence[tuple[str, float]], policy: ClarifyPolicy | None = None) -> Clarification:
    """Decide whether to act on the MAP command or ask "Did you mean A or B?".

    Args:
        commands: (command, probability) pairs, e.g. ``Posterior.commands``; any order.
        policy: threshold and cost (defaults: 0.6 and 0.1).
    """
    policy = policy or ClarifyPolicy()
    ranked = sorted(((str(c), float(p)) for c, p in commands), key=lambda cp: -cp[1])
    if not ranked:
        raise ObservationError("no commands to choose from; run inference first")
    (c1, p1) = ranked[0]
    evi = expected_value_of_asking([p for _c, p in ranked])
    options = tuple(c for c, _p in ranked[:2])
    if len(ranked) < 2:
        reason = "only one command is possible"
        ask = False
    elif p1 >= policy.threshold:
        reason = f"confident: P({c1}) = {p1:.2f} >= {policy.threshold:.2f}"
        ask = False
    elif evi <= policy.cost:
        reason = f"asking is not worth it: EVI {evi:.2f} <= cost {policy.cost:.2f}"
        ask = False
    else:
        reason = f"unsure: P({c1}) = {p1:.2f} < {policy.threshold:.2f} and EVI {evi:.2f} > cost {policy.cost:.2f}"
        ask = True
    question = ""
    if ask:
        a, b = (describe_command(c) for c in options)
        question = f"Did you mean {a} or {b}?"
    return Clarification(ask, c1, question, options, p1, evi, policy.threshold, policy.cost, reason)
