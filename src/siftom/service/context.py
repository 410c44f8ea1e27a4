"""What the service's routers share: one :class:`ServiceContext` per app, on ``app.state.context``.

A handler asks for it with the :data:`Ctx` dependency (HTTP requests and WebSockets alike).
CPU work goes through :class:`CpuRunner`: a worker thread under a capacity limit and the
request time limit, so the event loop stays responsive.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TypeVar

import anyio
import anyio.to_thread
from fastapi import Depends
from starlette.requests import HTTPConnection

from siftom.errors import UnknownNameError
from siftom.service.problems import PROBLEM_JSON, ProblemError

if TYPE_CHECKING:
    from siftom.options import ServiceSettings
    from siftom.service.runtime import Runtime
    from siftom.service.sessions import SessionManager
    from siftom.service.stream_state import Streams

R = TypeVar("R")
RunCpu = Callable[..., Awaitable[Any]]


class CpuRunner:
    """``await runner(fn, *args)``: ``fn`` in a worker thread, at most ``settings.workers`` at
    once, within the request time limit (a 503 when it runs over)."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self._limiter: anyio.CapacityLimiter | None = None  # made in the event loop, at first use

    async def __call__(self, fn: Callable[..., R], *args: Any) -> R:
        settings = self.runtime.settings
        if self._limiter is None:
            self._limiter = anyio.CapacityLimiter(settings.workers)
        self.runtime.requests += 1
        try:
            with anyio.fail_after(settings.request_timeout_s):
                return await anyio.to_thread.run_sync(functools.partial(fn, *args), limiter=self._limiter,
                                                      abandon_on_cancel=True)
        except TimeoutError:
            raise ProblemError(503, "timeout", f"the request took longer than {settings.request_timeout_s:g} s; "
                               "try again, or send a shorter recording", headers={"Retry-After": "2"}) from None


@dataclass(frozen=True)
class ServiceContext:
    """The shared parts of one app.

    Attributes:
        runtime: models, caches and locks (:mod:`siftom.service.runtime`).
        folder: the service's own folder (maps, sessions, perception cache, ratings).
        run_cpu: runs CPU work off the event loop (:class:`CpuRunner`).
        sessions: the session manager (:mod:`siftom.service.sessions`).
        streams: the open microphone streams (:mod:`siftom.service.stream_state`).
        settings_view: the resolved settings /healthz shows, secrets masked.
        ratings_lock: held while a rating is written (:mod:`siftom.service.ratings_api`).
    """

    runtime: Runtime
    folder: Path
    run_cpu: CpuRunner
    sessions: SessionManager
    streams: Streams
    settings_view: tuple[tuple[str, Any], ...] = ()
    ratings_lock: threading.Lock = field(default_factory=threading.Lock, compare=False)

    @property
    def settings(self) -> ServiceSettings:
        return self.runtime.settings

    def lookup(self, scenario_id: str, status: int) -> None:
        """A problem with ``status`` when ``scenario_id`` is not a registered scenario."""
        try:
            self.runtime.scenario(scenario_id)
        except UnknownNameError as exc:
            raise ProblemError(status, "unknown-scenario", str(exc)) from None


def service_context(conn: HTTPConnection) -> ServiceContext:
    """The app's :class:`ServiceContext` (a FastAPI dependency)."""
    ctx: ServiceContext = conn.app.state.context
    return ctx


Ctx = Annotated[ServiceContext, Depends(service_context)]


def problems(*codes: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` for problem answers with these status codes."""
    from siftom.service.schemas import Problem

    return {c: {"model": Problem, "content": {PROBLEM_JSON: {}}} for c in codes}


def media_type(conn: HTTPConnection) -> str:
    """The request's Content-Type without parameters, lowercased ('' when absent)."""
    return conn.headers.get("content-type", "").split(";")[0].strip().lower()


def is_json(media: str) -> bool:
    return media == "application/json" or media.endswith("+json")
