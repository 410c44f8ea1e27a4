"""Named, bounded memo caches shared by the scorers, with hit counts.

A scorer (an instruction likelihood) is frozen configuration with a pure ``log_prob``: what it
memoises goes to a :class:`Memo` of this module, keyed by everything the value depends on (the
scorer's configuration fingerprint included), so one scorer serves many threads with no lock
around its work and two scorers of different configuration never share a value. A memo's own
lock guards only its dictionary, never a computation: two threads that miss the same key both
compute it (the same value: the computation is pure) and the first stored wins.

``memo_stats()`` reports every memo by name (hits, misses, size, bound); the service shows them
in ``/healthz``.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

V = TypeVar("V")

_REGISTRY: dict[str, Memo[object]] = {}
_REGISTRY_LOCK = threading.Lock()


class Memo(Generic[V]):
    """A least-recently-used map of at most ``maxsize`` values, safe to share between threads."""

    def __init__(self, name: str, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError(f"a memo holds at least one value, got maxsize={maxsize}")
        self.name, self.maxsize = name, int(maxsize)
        self._d: OrderedDict[Hashable, V] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    def get(self, key: Hashable, make: Callable[[], V]) -> V:
        """The value for ``key``; ``make()`` (outside the lock) on a miss."""
        got = self.peek(key)
        return got if got is not None else self.put(key, make())

    def peek(self, key: Hashable) -> V | None:
        """The value for ``key`` if held (a hit), else None (a miss): for callers that make
        several missing values in one batch and :meth:`put` them."""
        with self._lock:
            if key in self._d:
                self._d.move_to_end(key)
                self.hits += 1
                return self._d[key]
            self.misses += 1
            return None

    def put(self, key: Hashable, value: V) -> V:
        """Store ``value`` unless another thread stored one first; the value held."""
        with self._lock:
            got = self._d.setdefault(key, value)
            self._d.move_to_end(key)
            while len(self._d) > self.maxsize:
                self._d.popitem(last=False)
        return got

    def clear(self) -> None:
        """Forget every value (the counts stay)."""
        with self._lock:
            self._d.clear()

    def __len__(self) -> int:
        return len(self._d)

    def stats(self) -> dict[str, int]:
        """``{hits, misses, size, maxsize}``."""
        with self._lock:
            return {"hits": self.hits, "misses": self.misses, "size": len(self._d), "maxsize": self.maxsize}


def memo(name: str, maxsize: int) -> Memo[V]:
    """The process's memo called ``name`` (created with ``maxsize`` on first use)."""
    with _REGISTRY_LOCK:
        got = _REGISTRY.get(name)
        if got is None:
            got = _REGISTRY[name] = Memo[object](name, maxsize)
    return got  # type: ignore[return-value]  # one name, one value type: the caller's


def memo_stats() -> dict[str, dict[str, int]]:
    """Every memo's counts, by name."""
    with _REGISTRY_LOCK:
        memos = list(_REGISTRY.values())
    return {m.name: m.stats() for m in sorted(memos, key=lambda m: m.name)}
