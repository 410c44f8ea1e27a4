"""The HTTP API and the web page: ``create_app(data_dir=None) -> FastAPI``.

Endpoints (docs/service.md has examples), one router per door:

* inference (:mod:`siftom.service.infer_api`): ``POST /v1/infer``, ``GET /v1/scenarios``,
  ``GET /v1/scenarios/{id}``, ``GET /v1/scenarios/{id}.png``, ``POST /v1/say``.
* perception (:mod:`siftom.service.perceive`): ``POST /v1/perceive`` and
  ``POST /v1/sessions/{id}/frames``.
* sessions (:mod:`siftom.service.session_api`): ``/v1/sessions``, a robot's own world,
  streamed actions, instructions.
* streams (:mod:`siftom.service.stream_api`): ``WS /v1/sessions/{id}/listen`` (streamed
  microphone audio, answered utterance by utterance) and ``POST /v1/sessions/from-scenario``.
* people (:mod:`siftom.service.ratings_api`): the ``/rate`` page and ratings of a trial.
* docs and meta (:mod:`siftom.service.meta_api`, :mod:`siftom.service.apidocs`): ``GET /healthz``,
  ``GET /openapi.json``, the API docs at ``/docs``, the web page at ``/``.

Every request is checked (:mod:`siftom.service.access`, docs/security.md): its ``Host``
(loopback names, IP addresses, ``settings.allowed_hosts``), the ``Origin`` of a POST, PUT,
PATCH, DELETE or WebSocket, and with a token (``settings.token``) the token on every request
but ``/healthz`` and the static files.

The routers share one :class:`~siftom.service.context.ServiceContext` (``app.state.context``).
CPU work runs in a worker thread under a capacity limit and a time limit, so the event loop
stays responsive; the shared parts are locked in :mod:`siftom.service.runtime`.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from pathlib import Path

from fastapi import APIRouter, FastAPI
from fastapi.staticfiles import StaticFiles

from siftom.observer import Observer
from siftom.service import infer_api, meta_api, perceive, ratings_api, session_api, stream_api
from siftom.service.access import Access, AccessGuard
from siftom.service.apidocs import install_docs
from siftom.service.context import CpuRunner, ServiceContext
from siftom.service.problems import BodyLimitMiddleware, SecurityHeadersMiddleware, install_handlers
from siftom.service.runtime import Runtime, ServiceSettings, default_data_dir
from siftom.service.sessions import SessionManager
from siftom.service.store import SessionStore
from siftom.service.stream_state import Streams
from siftom.settings import Settings

STATIC = meta_api.STATIC


@contextlib.asynccontextmanager
async def _lifespan(app: FastAPI) -> AsyncIterator[None]:
    """Start-up: load the default audio model in the background, so the first recording does
    not wait for it."""
    app.state.runtime.warm_up()
    yield


def _add_door(app: FastAPI, router: APIRouter) -> None:
    """The door's routes on the app, in order, as if declared on it: ``app.routes`` lists every
    route (FastAPI's ``include_router`` may keep them behind one entry; the API reference's build
    reads them). The routers declare no prefix, dependencies or tags of their own to inherit."""
    app.router.routes.extend(router.routes)


def _context(settings: ServiceSettings, full: Settings, folder: Path, observer: Observer,
             owns_dir: bool) -> ServiceContext:
    """The shared parts: runtime, session store and manager, open streams."""
    rt = Runtime(settings, folder, observer, owns_dir=owns_dir)  # a temporary folder goes on close
    store = SessionStore(folder / "sessions.sqlite3")
    rt.closers.append(store.close)
    return ServiceContext(runtime=rt, folder=folder, run_cpu=CpuRunner(rt),
                          sessions=SessionManager(store, settings.sessions, rt.observer),
                          streams=Streams(settings.stream, settings.request_timeout_s),
                          settings_view=meta_api.settings_view(full, settings.token))


def create_app(data_dir: str | Path | None = None, settings: ServiceSettings | Settings | None = None,
               observer: Observer | None = None) -> FastAPI:
    """Build the app.

    Args:
        data_dir: the service's own folder (map PNG cache, sessions); a fresh temporary folder
            if None, removed by ``app.state.runtime.close()``. No request reads or writes
            anywhere else. Files are created 0600 in 0700 folders.
        settings: every option (a ``Settings``: its ``service`` section gives the limits), or the
            service's limits alone (``ServiceSettings``; the rest from :meth:`Settings.load`).
        observer: the observer every inference goes through (default: one built from the settings).
    """
    if isinstance(settings, Settings):
        full: Settings = settings
        settings = full.service
    else:
        full = observer.settings if observer is not None else Settings.load()
        settings = settings or full.service
    if observer is None:
        observer = Observer(full, offered=settings.offered, max_audio_seconds=settings.max_audio_seconds)
    folder = Path(data_dir) if data_dir is not None else default_data_dir()
    ctx = _context(settings, observer.settings, folder, observer, owns_dir=data_dir is None)
    app = FastAPI(title="siftom", version=meta_api.version(), docs_url=None, redoc_url=None, lifespan=_lifespan,
                  description="Follow noisy spoken instructions by inferring what the person is doing (SIFToM).")
    app.state.context = ctx
    app.state.runtime, app.state.sessions, app.state.streams = ctx.runtime, ctx.sessions, ctx.streams.open
    install_handlers(app)
    app.add_middleware(BodyLimitMiddleware, max_bytes=settings.max_body_bytes)
    access = Access(token=settings.token, hosts=settings.allowed_hosts, origins=settings.allowed_origins)
    app.add_middleware(AccessGuard, access=access)  # Host, Origin, token: docs/security.md
    app.add_middleware(SecurityHeadersMiddleware)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    _add_door(app, meta_api.router)  # the page, /healthz
    install_docs(app)  # GET /docs: interactive API docs from local files, no CDN
    _add_door(app, infer_api.router)  # /v1/scenarios, /v1/infer, /v1/say
    _add_door(app, perceive.router)  # POST /v1/perceive, POST /v1/sessions/{id}/frames
    _add_door(app, session_api.router)  # /v1/sessions
    _add_door(app, stream_api.router)  # WS /v1/sessions/{id}/listen, POST /v1/sessions/from-scenario
    _add_door(app, ratings_api.router)  # the /rate page and POST /v1/sessions/{id}/rating
    offered = settings.offered
    app.openapi = lambda: meta_api.openapi_for(app, offered)  # type: ignore[method-assign]
    return app
