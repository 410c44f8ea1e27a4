"""The instruction-likelihood interface P(phi | pi_r) (paper, Methods, Instruction Likelihood).

Every implementation is an object with one method, ``log_prob``, returning a :class:`Scores`
record: for each candidate robot command the log-likelihood of what was heard, and the evidence
the likelihood used besides the N-best (e.g. the words Whisper heard). Scores need only be
comparable across the candidates of one call (constants that do not depend on the command
cancel in the posterior). A likelihood keeps no state from one call to the next, so one object
may score several requests at once.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from siftom.concurrency import guarded
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

__all__ = ["Hypothesis", "Instruction", "InstructionLikelihood", "Scores", "as_scores", "guarded"]



@dataclass(frozen=True, eq=False)
class Scores:
    """What one ``log_prob`` call returns.

    Attributes:
        log_probs: log P(phi | pi_r) per candidate command, shape (len(commands),).
        evidence: what the likelihood used besides the N-best, JSON-able (shown with the
            posterior as ``evidence``), e.g. ``{"acoustic_mode": "key", "whisper_heard": "..."}``.
    """

    log_probs: np.ndarray
    evidence: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        arr = np.asarray(self.log_probs, dtype=np.float64)
        arr.setflags(write=False)
        object.__setattr__(self, "log_probs", arr)
        object.__setattr__(self, "evidence", MappingProxyType(dict(self.evidence)))

    def __len__(self) -> int:
        return len(self.log_probs)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        return np.array(self.log_probs, dtype=dtype)


def as_scores(result: Scores | np.ndarray | Sequence[float]) -> Scores:
    """A likelihood's result as Scores (a bare array of log-likelihoods has no evidence)."""
    return result if isinstance(result, Scores) else Scores(np.asarray(result, dtype=np.float64))


@runtime_checkable
class InstructionLikelihood(Protocol):
    """log P(phi | pi_r) for each candidate robot command."""

    name: str

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> Scores:
        """Return the log-likelihood of each command (shape (len(commands),)) and the evidence used."""
        ...
