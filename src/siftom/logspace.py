"""Log-space sums: the one place probabilities are normalised (STYLE.md, principle 4)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.typing import ArrayLike


def logsumexp(x: ArrayLike, axis: int | None = None) -> np.ndarray:
    """log(sum(exp(x))) along ``axis``, stable (all -inf gives -inf)."""
    a = np.asarray(x, dtype=np.float64)
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        out: npt.NDArray[np.float64] = np.log(np.sum(np.exp(a - m), axis=axis, keepdims=True)) + m
    return out.squeeze(axis=axis) if axis is not None else out.reshape(())


def group_logsumexp(x: np.ndarray, groups: np.ndarray, n: int) -> np.ndarray:
    """logsumexp of ``x`` within each group (0..n-1); -inf for empty groups."""
    m = np.full(n, -np.inf)
    np.maximum.at(m, groups, x)
    m_safe = np.where(np.isfinite(m), m, 0.0)
    s = np.bincount(groups, weights=np.exp(x - m_safe[groups]), minlength=n)
    with np.errstate(divide="ignore"):
        return np.log(s) + m_safe
