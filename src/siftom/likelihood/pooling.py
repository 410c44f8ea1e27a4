"""How the acoustic likelihood's experts meet (:mod:`siftom.likelihood.acoustic`).

Two experts score every command from the same recording: the recogniser's N-best through the
phonetic channel (``P_N``) and Whisper's teacher-forced scores of each command's words
(``P_W``, the Whisper factor at T_w). A third voice is Whisper's own transcript, read by the slot
channel (``siftom.language.understand.slot_log_factor``).

**Pool** (``pool``): ``"product"`` (the default) multiplies the two experts, log P_N + w / T_w;
one of them sure of a wrong command then carries the answer whatever the other says.
``"mixture"`` pools them linearly: each is normalised over the call's commands and

    log P(a | pi_r) = log( 1/2 softmax(log P_N)_r + 1/2 softmax(w / T_w)_r )

where the experts agree the pool is as sharp as they are; where they disagree it stays between
them, so the actions (or neither) decide, and the posterior flattens instead of following the
more confident expert. No constant: equal weights, the existing T_w. It gives the fewest
confident wrong answers but is not the default: on two of the evaluation plan's household cells
it lost more than a point, and where the Whisper factor barely separates counts it flattens a
count the recogniser heard right ("i need four teaspoons": deliver(spoon,4) 0.16 against 0.91). ``"tempered"`` keeps the
product but divides it by a temperature that grows with the experts' disagreement: times
(1 - TV), TV the total variation distance between the two normalised experts (1 - TV = 1 where
they agree, 0, flat, where they share no mass); measured beside the mixture, not the default.

**Whisper's transcript in the slot channel** (``whisper_slot_confidence``): the transcript is
Whisper's greedy guess and is often made-up words on noisy or accented speech ("the tasmine
oil" for "milk"); read at full weight its target slot can move a command by the slot channel's
cap (12 nats). Weighted by its own confidence c = exp(mean token log-probability) (Whisper's
``avg_logprob``: the geometric mean probability of its tokens), it is a mixture of "the
transcript's slot" (weight c) and "the slot was lost" (weight 1 - c, which favours no command).
This one is on by default. docs/likelihoods.md ("Confident wrong answers") gives the
measurements behind both choices.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.logspace import logsumexp

if TYPE_CHECKING:
    from siftom.likelihood.lexicon import Lexicon
    from siftom.world.commands import RobotCommand

POOLS = ("mixture", "product", "tempered")
# the product: the mixture was best on the dev set but lost more than a point on two of the plan's
# household cells and flattens counts heard right ("i need four teaspoons"); docs/likelihoods.md
DEFAULT_POOL = "product"


def pool_experts(phonetic: np.ndarray | None, whisper: np.ndarray | float, pool: str) -> np.ndarray | float:
    """The N-best's log-likelihoods and the Whisper term (w / T_w) pooled (module doc); either may
    be missing (None / a scalar), and then the other is returned unchanged."""
    if pool not in POOLS:
        raise ValueError(f"pool must be one of {POOLS}, got {pool!r}")
    w = np.asarray(whisper, dtype=float)
    if phonetic is None:
        return whisper
    if pool == "product" or w.ndim == 0:
        return phonetic + whisper
    p = np.asarray(phonetic, dtype=float)
    lp, lw = p - logsumexp(p), w - logsumexp(w)
    if pool == "tempered":
        agree = 1.0 - 0.5 * float(np.abs(np.exp(lp) - np.exp(lw)).sum())
        tempered: np.ndarray = (p + w) * max(agree, 0.0)
        return tempered
    pooled: np.ndarray = np.logaddexp(lp, lw) - np.log(2.0)
    return pooled


def transcript_confidence(logprob: float | None) -> float:
    """exp(mean token log-probability) in [0, 1]: 0 for no transcript (None or -inf)."""
    if logprob is None or not np.isfinite(logprob):
        return 0.0
    return float(np.clip(np.exp(float(logprob)), 0.0, 1.0))


def whisper_slot_factor(heard: str, logprob: float | None, commands: Sequence[RobotCommand],
                        lexicon: Lexicon | None, focus: int | None, weighted: bool = True) -> Any:
    """The slot channel's log-factor per command for Whisper's transcript ``heard``; ``weighted``:
    a mixture of the transcript (weight :func:`transcript_confidence`) and no slot (the rest)."""
    from siftom.language.understand import slot_log_factor

    if not weighted:
        return slot_log_factor([heard], [1.0], commands, lexicon, focus)
    c = transcript_confidence(logprob)
    return slot_log_factor([heard, ""], [c, 1.0 - c], commands, lexicon, focus)
