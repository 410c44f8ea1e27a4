"""The hypotheses of a posterior: one (goal, command) pair with its terms, or all of them as arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from siftom.world.commands import RobotCommand
from siftom.world.model import Goal, State


class ScoredCommand(NamedTuple):
    """A command and its posterior probability: a pair (``for c, p in posterior.commands``),
    printed readably: ``(fetch(cereal), 0.832)``."""

    command: RobotCommand
    prob: float

    def __repr__(self) -> str:
        return f"({self.command}, {self.prob:.3f})"


class ScoredGoal(NamedTuple):
    """A goal's name and its posterior probability, printed as ``(breakfast_cereal, 0.610)``."""

    goal: str
    prob: float

    def __repr__(self) -> str:
        return f"({self.goal}, {self.prob:.3f})"


@dataclass(frozen=True)
class JointHypothesis:
    """One (goal, command) pair with its posterior and each term's contribution (log)."""

    goal: str
    command: RobotCommand
    prob: float
    log_prior: float
    log_action: float
    log_instruction: float


@dataclass(frozen=True, eq=False)
class JointPosterior:
    """Every (goal, command) hypothesis with its probability, as arrays (for decision rules).

    ``goal_idx[i]`` indexes ``goals`` (``len(goals)`` is the unknown goal), ``cmd_idx[i]``
    indexes ``commands``; ``log_joint[i]`` is the unnormalised log probability, so another
    factor that depends on the command alone (a second utterance) can be added exactly.
    ``log_words[k]``: what the words alone say of command k (the instruction term, log
    P(words | command) up to a constant), None when nothing was heard.
    """

    goals: tuple[Goal, ...]
    commands: tuple[RobotCommand, ...]
    goal_idx: np.ndarray
    cmd_idx: np.ndarray
    log_joint: np.ndarray
    state: State | None = None
    log_words: np.ndarray | None = None
