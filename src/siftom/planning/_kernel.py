"""Compiled core of the cost-to-go (optional: used when numba is installed, ``siftom[fast]``).

One fused loop replaces the ~25 small numpy calls of ``CostToGo._values_t``, whose per-call
overhead dominates at the sizes inference uses (hundreds of goals, a handful of classes each).
Both paths compute the same numbers; the tests run them against each other.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np
import numpy.typing as npt

from siftom.settings.environment import numba_disabled

_F = TypeVar("_F", bound=Callable[..., Any])

_njit: Callable[..., Any] | None
try:  # optional dependency
    if numba_disabled():
        raise ImportError("disabled by SIFTOM_NO_NUMBA")
    from numba import njit as _njit
except ImportError:  # pragma: no cover - exercised when numba is absent
    _njit = None

AVAILABLE = _njit is not None

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
Bool = npt.NDArray[np.bool_]


def njit(**options: Any) -> Callable[[_F], _F]:
    """numba's ``njit(**options)``, typed: the compiled function keeps its Python signature."""
    assert _njit is not None
    return cast(Callable[[_F], _F], _njit(**options))

if AVAILABLE:

    @njit(cache=True, nogil=True, inline="always")
    def _popcount(x: int | np.int64) -> int:  # pragma: no cover - compiled
        n = 0
        while x:
            x &= x - 1
            n += 1
        return n

    @njit(cache=True, nogil=True, inline="always")
    def _prepare(cum_flat: F64, opens_flat: I64, fl: I64, pos: Bool, m: int, relaxed: bool, others: I64,
                 n_others: I64) -> tuple[float, np.int64]:  # pragma: no cover - compiled
        """Round trips, containers they open, and per class the containers the others open."""
        body = 0.0
        ob = np.int64(0)
        for j in range(m):
            body += cum_flat[fl[j]]
            ob |= opens_flat[fl[j]]
        if not relaxed:
            for j in range(m):
                o = np.int64(0)
                if pos[j]:
                    for k in range(m):
                        if k != j:
                            o |= opens_flat[fl[k]]
                    n_others[j] = _popcount(o)
                others[j] = ~o
        return body, ob

    @njit(cache=True, nogil=True, inline="always")
    def _first_trip(delta2: F64, fdelta2: F64, fmask2: I64, fl: I64, pos: Bool, m: int, p: int, relaxed: bool,
                    others: I64, n_others: I64, inf: float) -> float:  # pragma: no cover
        ft = inf
        for j in range(m):
            if pos[j]:
                if relaxed:
                    dv = delta2[fl[j], p]
                else:
                    dv = fdelta2[fl[j], p] + n_others[j] + _popcount(fmask2[fl[j], p] & others[j])
                if dv < ft:
                    ft = dv
        return ft

    @njit(cache=True, nogil=True)
    def values_kernel(cum_flat: F64, opens_flat: I64, delta2: F64, fdelta2: F64, fmask2: I64, at_target: I64,
                      d_target: F64, idx: I64, cnt: I64, q: I64, held: I64, k1: int,
                      relaxed: bool, inf: float) -> F64:  # pragma: no cover - compiled
        m, g_n = idx.shape
        q_n = q.shape[0]
        out = np.empty((q_n, g_n))
        fl = np.empty(m, dtype=np.int64)
        pos = np.empty(m, dtype=np.bool_)
        others = np.empty(m, dtype=np.int64)
        n_others = np.empty(m, dtype=np.int64)
        # the same with the held object put down and left (empty hands)
        fl2 = np.empty(m, dtype=np.int64)
        pos2 = np.empty(m, dtype=np.bool_)
        others2 = np.empty(m, dtype=np.int64)
        n_others2 = np.empty(m, dtype=np.int64)
        for g in range(g_n):
            hc = held[g]
            any_need = False
            deliver = False
            for j in range(m):
                c = idx[j, g]
                n = cnt[j, g] - at_target[c]
                if n < 0:
                    n = 0
                e = n
                if hc >= 0 and c == hc and n > 0:
                    e = n - 1
                    deliver = True
                fl[j] = c * k1 + e
                fl2[j] = c * k1 + n
                pos[j] = e > 0
                pos2[j] = n > 0
                if e > 0:
                    any_need = True
            body, ob = _prepare(cum_flat, opens_flat, fl, pos, m, relaxed, others, n_others)
            body2 = 0.0
            extra = 0.0  # the held class's next round trip, which leaving the object costs
            ready = False
            n_ob = 0
            if deliver:
                for j in range(m):
                    if fl2[j] != fl[j]:
                        extra = cum_flat[fl2[j]] - cum_flat[fl[j]]
                if not relaxed:
                    n_ob = _popcount(ob)
            for qi in range(q_n):
                p = q[qi]
                if deliver:
                    # deliver it first (then round trips only), or put it down here and leave it
                    v = d_target[p] + 1.0 + body + n_ob
                    # leaving it costs at least 1 + extra - d(p, T) more than the round trips
                    # (a first trip saves at most d(p, T)): only then is it worth computing
                    if 1.0 + body + extra - d_target[p] < v:
                        if not ready:
                            body2, _ob2 = _prepare(cum_flat, opens_flat, fl2, pos2, m, relaxed, others2, n_others2)
                            ready = True
                        v2 = 1.0 + body2 + _first_trip(delta2, fdelta2, fmask2, fl2, pos2, m, p, relaxed, others2,
                                                       n_others2, inf)
                        if v2 < v:
                            v = v2
                else:
                    ft = 0.0
                    if any_need:
                        ft = _first_trip(delta2, fdelta2, fmask2, fl, pos, m, p, relaxed, others, n_others, inf)
                    v = body + ft
                    if hc >= 0 and any_need:
                        v += 1.0
                out[qi, g] = v if v < inf else inf
        return out
