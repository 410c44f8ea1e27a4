"""Boltzmann policy over Q-values: P(a | s, g) proportional to exp(-beta * Q*(s, a; g)).

Q is a cost here (steps to finish), so lower is better. ``beta`` is the rationality
(1/temperature, per step of cost); ``epsilon`` mixes in a uniform choice so that no legal
action ever has probability zero (paper, Eq. 2; SymbolicPlanners.jl's BoltzmannPolicy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from siftom.errors import OptionsError


@dataclass(frozen=True)
class BoltzmannPolicy:
    """log P(a | s) = log((1 - eps) softmax(-beta Q)_a + eps / |A|)."""

    beta: float = 1.0
    epsilon: float = 0.01

    def __post_init__(self) -> None:
        if not (self.beta >= 0 and np.isfinite(self.beta)):
            raise OptionsError(f"beta must be a finite number >= 0 (0: uniform), got {self.beta}")
        if not 0 <= self.epsilon < 1:
            raise OptionsError(f"epsilon must be in [0, 1) (e.g. 0.01), got {self.epsilon}")

    def log_probs(self, Q: np.ndarray) -> np.ndarray:
        """Log-probabilities over actions (axis 0) for each column of ``Q`` (actions x goals)."""
        z = -self.beta * np.minimum(Q, 1e6)
        lp: np.ndarray = z - logsumexp(z, axis=0, keepdims=True)
        if self.epsilon > 0:
            n = Q.shape[0]
            lp = np.logaddexp(np.log1p(-self.epsilon) + lp, np.log(self.epsilon / n))
        return lp
