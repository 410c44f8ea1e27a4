"""The parts the SIFToM posterior is assembled from (paper, Eq. 1-3; InversePlanning.jl style).

    log P(g, pi_r | actions, phi) = log P(g) + log P(pi_r | g) + sum_t log P(a_t | s_t, pi_h)
                                     + log P(phi | pi_r) - log Z

Each term is an object: :class:`GoalPrior`, :class:`HelpfulPartPrior`, :class:`BoltzmannActions`
(and :class:`UniformActions` for the "unknown goal"); the instruction term is any
:class:`~siftom.likelihood.base.InstructionLikelihood`. :class:`~siftom.inference.model.OnlineInference`
only adds them and normalises. docs/inference.md gives the reasons for each choice.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from siftom.logspace import group_logsumexp, logsumexp


@dataclass(frozen=True)
class GoalPrior:
    """P(g): uniform over the goals that still leave the robot something to do, with
    ``unknown_prior`` mass on "unknown goal" (uniform over the domain's commands)."""

    unknown_prior: float = 0.02

    def log_known(self, goal_idx: np.ndarray, n_goals: int) -> float:
        """log P(g) for each known goal that has a candidate robot part."""
        has = np.bincount(goal_idx, minlength=n_goals) > 0
        return float(np.log1p(-self.unknown_prior) - np.log(max(int(has.sum()), 1)))

    def log_unknown(self, n_commands: int) -> float:
        """log P(unknown goal, pi_r) for each of its ``n_commands`` commands."""
        if self.unknown_prior <= 0:
            return -math.inf
        return math.log(self.unknown_prior) - math.log(n_commands)


@dataclass(frozen=True)
class HelpfulPartPrior:
    """P(pi_r | g): softmax over the goal's possible robot parts of ``kappa`` x the steps the
    part saves the human (useful, non-redundant help)."""

    kappa: float = 0.1

    def log_prob(self, steps_saved: np.ndarray, goal_idx: np.ndarray, n_goals: int) -> np.ndarray:
        z = self.kappa * steps_saved
        lp: np.ndarray = z - group_logsumexp(z, goal_idx, n_goals)[goal_idx]
        return lp


@dataclass
class BoltzmannActions:
    """P(a_t | s_t, pi_h) = (1 - eps) softmax(-beta Q*)_a + eps / |A|, with beta marginalised over
    a uniform grid: the whole trajectory under each beta, then the mixture (beta is one constant
    of the person). The same distribution as :class:`siftom.planning.policy.BoltzmannPolicy`,
    evaluated at the observed action for every hypothesis row and every beta at once.

    State: the cumulative log-likelihood per row and beta, so one more action costs one update.
    """

    betas: Sequence[float]
    epsilon: float
    n_rows: int
    _beta: np.ndarray = field(init=False, repr=False)
    _doubling: list[bool] = field(init=False, repr=False)
    cumulative: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._beta = np.asarray(self.betas, dtype=np.float64)
        self._doubling = [b > 0 and self._beta[b] == 2 * self._beta[b - 1] for b in range(len(self._beta))]
        self.cumulative = np.zeros((self.n_rows, len(self._beta)))

    def step_log_lik(self, Q: np.ndarray, k: int) -> np.ndarray:
        """log P(a_k | s) for every row (columns of ``Q``, actions x rows) and beta: (R, B).

        With Qs = Q - min_a Q >= 0, log P_beta(a_k) = -beta Qs[k] - log sum_a exp(-beta Qs[a]).
        For a grid where each beta doubles the previous one, exp(-2 beta Qs) is the square of
        exp(-beta Qs): one exp for the whole grid.
        """
        Qc = np.minimum(Q, 1e6)
        Qs = Qc - Qc.min(axis=0)
        lp = np.empty((len(self._beta), Q.shape[1]))
        E = None
        for b, beta in enumerate(self._beta):
            E = E * E if E is not None and self._doubling[b] else np.exp(-beta * Qs)
            lp[b] = -beta * Qs[k] - np.log(E.sum(axis=0))
        if self.epsilon > 0:
            lp = np.logaddexp(np.log1p(-self.epsilon) + lp, np.log(self.epsilon / Q.shape[0]))
        return lp.T

    def observe(self, Q: np.ndarray, k: int) -> None:
        """Add the observed action ``k`` of the legal actions whose Q-values are ``Q``."""
        self.cumulative += self.step_log_lik(Q, k)

    def log_lik(self, rows: np.ndarray) -> np.ndarray:
        """sum_t log P(a_t | s_t, row) with beta marginalised, for the given rows."""
        ll: np.ndarray = (logsumexp(self.cumulative, axis=1) - np.log(len(self._beta)))[rows]
        return ll


@dataclass
class UniformActions:
    """The "unknown goal" human: every legal action equally likely at each step."""

    cumulative: float = 0.0

    def observe(self, n_legal: int) -> None:
        self.cumulative -= math.log(n_legal)
