"""Walking costs between places from their positions and the doors between rooms (docs/world.md)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np

STEP_METRES = 1.0  # one walking step covers this many metres (docs/world.md)


class Located(Protocol):
    """Anything with a floor position and a room (a :class:`~siftom.world.model.Place`)."""

    @property
    def pos(self) -> tuple[float, float]: ...

    @property
    def room(self) -> str: ...


def walking_costs(
    places: Sequence[Located], doors: Mapping[frozenset[str], tuple[float, float]] | None = None,
    step: float = STEP_METRES,
) -> np.ndarray:
    """Integer walking costs: Euclidean within a room, shortest path through doors across rooms.

    Cost is ``max(1, ceil(metres / step))`` between distinct places. Rooms not linked by a
    door chain are linked directly through their centres (documented default).
    """
    n = len(places)
    pts = [p.pos for p in places]
    door_list = list((doors or {}).items())
    # graph nodes: places + doors; edges within the same room
    node_pts = pts + [d[1] for d in door_list]
    node_rooms: list[frozenset[str]] = [frozenset({p.room}) for p in places] + [d[0] for d in door_list]
    m = len(node_pts)
    w = np.full((m, m), np.inf)
    for a in range(m):
        w[a, a] = 0.0
        for b in range(a + 1, m):
            if node_rooms[a] & node_rooms[b]:
                dd = math.dist(node_pts[a], node_pts[b])
                w[a, b] = w[b, a] = dd
    from scipy.sparse.csgraph import shortest_path

    sp = shortest_path(np.where(np.isfinite(w), w, 0.0), method="D", directed=False)
    sp = np.where(np.isfinite(w) | (sp > 0), sp, np.inf)
    out = np.zeros((n, n), dtype=np.int64)
    for a in range(n):
        for b in range(n):
            if a == b:
                continue
            dd = sp[a, b]
            if not np.isfinite(dd):
                dd = math.dist(pts[a], pts[b])
            out[a, b] = max(1, math.ceil(dd / step - 1e-9))
    return out
