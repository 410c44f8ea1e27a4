"""Compiled core of the cost-to-go (optional: used when numba is installed, ``siftom[fast]``).

One fused loop replaces the ~25 small numpy calls of ``CostToGo._values_t``, whose per-call
overhead dominates at the sizes inference uses (hundreds of goals, a handful of classes each).
Both paths compute the same numbers; the tests run them against each other.
"""

from __future__ import annotations

import os

import numpy as np

try:  # optional dependency
    if os.environ.get("SIFTOM_NO_NUMBA"):
        raise ImportError("disabled by SIFTOM_NO_NUMBA")
    from numba import njit
except ImportError:  # pragma: no cover - exercised when numba is absent
    njit = None

AVAILABLE = njit is not None

if AVAILABLE:

    @njit(cache=True, nogil=True, inline="always")
    def _popcount(x):  # pragma: no cover - compiled
        n = 0
        while x:
            x &= x - 1
            n += 1
        return n

    @njit(cache=True, nogil=True, inline="always")
    def _prepare(cum_flat, opens_flat, fl, pos, m, relaxed, others, n_others):  # pragma: no cover - compiled
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
    def _first_trip(delta2, fdelta2, fmask2, fl, pos, m, p, relaxed, others, n_others, inf):  # pragma: no cover
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
    def values_kernel(cum_flat, opens_flat, delta2, fdelta2, fmask2, at_target, d_target, idx, cnt, q, held, k1,
                      relaxed, inf):  # pragma: no cover - compiled
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
