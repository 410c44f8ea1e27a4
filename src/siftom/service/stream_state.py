"""The app's open microphone streams: which session streams where, how many are admitted, and
the worker threads their answers run in (apart from the HTTP requests' own)."""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import anyio
import anyio.to_thread

from siftom.service.problems import ProblemError
from siftom.service.stream_settings import StreamLimits

R = TypeVar("R")


class StreamGone(Exception):
    """The stream closed before this utterance was answered: its answer is cancelled."""


@dataclass
class OpenStream:
    """One session's open stream: the task running it, and whether a newer connection took it over."""

    task: asyncio.Task[None] | None = None
    taken_over: bool = False


class Streams:
    """The open streams of one app.

    Attributes:
        limits: the streaming limits (``ServiceSettings.stream``).
        open: session id -> its open stream (one per session).
        admitted: streams past the ``max_streams`` check (counted before any await: no race).
    """

    def __init__(self, limits: StreamLimits, timeout_s: float) -> None:
        self.limits, self.timeout_s = limits, timeout_s
        self.open: dict[str, OpenStream] = {}
        self.admitted = 0
        # streams wait for their answers in threads of their own: HTTP requests never queue behind them
        self._threads = anyio.CapacityLimiter(limits.max_streams)

    async def run_answer(self, fn: Callable[..., R], *args: Any) -> R:
        """``fn(*args)`` in one of the streams' worker threads, within the time limit (a 503 past it)."""
        try:
            with anyio.fail_after(self.timeout_s):
                return await anyio.to_thread.run_sync(functools.partial(fn, *args), limiter=self._threads,
                                                      abandon_on_cancel=True)
        except TimeoutError:
            raise ProblemError(503, "timeout", f"the answer took longer than {self.timeout_s:g} s") from None
