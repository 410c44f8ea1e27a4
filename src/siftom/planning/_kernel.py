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

    @njit(cache=True, nogil=True)
    def _popcount(x):  # pragma: no cover - compiled
        n = 0
        while x:
            x &= x - 1
            n += 1
        return n

    @njit(cache=True, nogil=True)
    def values_kernel(cum_flat, opens_flat, delta2, fdelta2, fmask2, at_target, d_target, idx, cnt, q, held, k1,
                      relaxed, inf):  # pragma: no cover - compiled
        m, g_n = idx.shape
        q_n = q.shape[0]
        out = np.empty((q_n, g_n))
        fl = np.empty(m, dtype=np.int64)
        pos = np.empty(m, dtype=np.bool_)
        ow = np.empty(m, dtype=np.int64)
        others = np.empty(m, dtype=np.int64)
        n_others = np.empty(m, dtype=np.int64)
        for g in range(g_n):
            hc = held[g]
            body = 0.0
            ob = np.int64(0)
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
                f = c * k1 + e
                fl[j] = f
                pos[j] = e > 0
                if e > 0:
                    any_need = True
                body += cum_flat[f]
                ow[j] = opens_flat[f]
                ob |= ow[j]
            if not relaxed and any_need and not deliver:
                # containers the other classes open (this class's own come with its first trip)
                for j in range(m):
                    o = np.int64(0)
                    if pos[j]:
                        for k in range(m):
                            if k != j:
                                o |= ow[k]
                        n_others[j] = _popcount(o)
                    others[j] = ~o
            for qi in range(q_n):
                p = q[qi]
                if deliver:
                    v = d_target[p] + 1.0 + body
                    if not relaxed:
                        v += _popcount(ob)
                else:
                    ft = inf
                    if any_need:
                        for j in range(m):
                            if pos[j]:
                                if relaxed:
                                    dv = delta2[fl[j], p]
                                else:
                                    dv = fdelta2[fl[j], p] + n_others[j] + _popcount(fmask2[fl[j], p] & others[j])
                                if dv < ft:
                                    ft = dv
                    else:
                        ft = 0.0
                    v = body + ft
                    if hc >= 0 and any_need:
                        v += 1.0
                out[qi, g] = v if v < inf else inf
        return out
