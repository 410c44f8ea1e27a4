"""One lock per object, for objects that many threads share (likelihoods, decoders).

A likelihood keeps nothing from one call to the next but memo caches, and a recogniser holds a
native decoder that decodes one utterance at a time; :func:`guarded` runs a method under its
object's own re-entrant lock, so one object can serve many request threads. The lock lives
outside the object (a weak map), so the object stays picklable.
"""

from __future__ import annotations

import functools
import threading
import weakref
from collections.abc import Callable
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])
_LOCKS: weakref.WeakKeyDictionary[Any, threading.RLock] = weakref.WeakKeyDictionary()
_LOCKS_LOCK = threading.Lock()


def _lock_of(obj: Any) -> threading.RLock:
    with _LOCKS_LOCK:
        lock = _LOCKS.get(obj)
        if lock is None:
            lock = _LOCKS[obj] = threading.RLock()
        return lock


def guarded(method: F) -> F:
    """Run ``method`` under its object's own lock: for likelihoods whose memo caches (or native
    decoders) may not be touched by two threads at once. Results never depend on the caches,
    and nothing survives a call but them; objects stay picklable (the lock lives outside)."""

    @functools.wraps(method)
    def wrapper(self: Any, *args: Any, **kwargs: Any) -> Any:
        with _lock_of(self):
            return method(self, *args, **kwargs)

    return cast(F, wrapper)


_MAKING = threading.Lock()


def make_once(obj: object, attr: str, make: Callable[[], Any]) -> None:
    """Set ``obj.attr = make()`` unless it is set already (None means unset), once across
    threads: for lazily loaded native decoders, each of which guards its own state. Only the
    making is serialised, never the work of the object that holds them."""
    with _MAKING:
        if getattr(obj, attr) is None:
            setattr(obj, attr, make())
