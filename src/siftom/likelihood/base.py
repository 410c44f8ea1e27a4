"""The instruction-likelihood interface P(phi | pi_r) (paper, Methods, Instruction Likelihood).

Every implementation is an object with one method, ``log_prob``, returning for each candidate
robot command the log-likelihood of what was heard. Scores need only be comparable across the
candidates of one call (constants that do not depend on the command cancel in the posterior).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

__all__ = ["Hypothesis", "Instruction", "InstructionLikelihood"]


@runtime_checkable
class InstructionLikelihood(Protocol):
    """log P(phi | pi_r) for each candidate robot command."""

    name: str

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> np.ndarray:
        """Return an array of shape (len(commands),) of log-likelihoods."""
        ...
