"""Which objects the cost-to-go's plan fetches (the team-value utility reserves them for the robot)."""

from __future__ import annotations

import numpy as np

from siftom.planning.costtogo import CostToGo, fetch_order
from siftom.world.model import HELD, State


def chosen(ctg: CostToGo, s: State, c: int, k: int, q: int | None) -> list[int]:
    """The ``k`` objects of class ``c`` the tables' plan fetches, the first from place ``q``.

    The same choice ``_class_rows`` makes for the full value (class ``c`` alone): the place
    the first object comes from minimises walking plus the containers opened; the others
    are the cheapest round trips of the rest. ``q=None``: round trips only (no first trip).
    """
    T = ctg.target
    items = [i for i in ctg._cls_items[c].tolist() if s.item_at[i] not in (HELD, T)]
    if k <= 0 or not items:
        return []
    avail = [s.item_at[i] for i in items]
    sites = sorted(set(avail))
    size = {u: avail.count(u) for u in sites}
    closed = {u: bool(ctg._closable[u] and not s.is_open(u)) for u in sites}

    def take(seq: list[int]) -> list[int]:
        left = list(items)
        out = []
        for u in seq:
            i = next(i for i in left if s.item_at[i] == u)
            left.remove(i)
            out.append(i)
        return out

    seq = fetch_order(sites, size, closed, ctg._dT)
    if q is None:
        return take(seq[:k])
    best, pick = np.inf, seq[:k]
    for u in dict.fromkeys(seq):
        size_u = dict(size)
        size_u[u] -= 1
        order = [u] + fetch_order(sites, size_u, {**closed, u: False}, ctg._dT)[: k - 1]
        bits = 0
        for v in order:
            bits |= (1 << v) if closed[v] else 0
        tot = float(sum(2.0 * ctg._dT[v] + 2.0 for v in order)) + ctg._d[q, u] - ctg._dT[u] + bits.bit_count()
        if tot < best:
            best, pick = tot, order
    return take(pick)
