"""The HTTP API and the web page: ``create_app(data_dir=None) -> FastAPI``.

Endpoints (docs/service.md has examples):

* ``POST /v1/infer``: JSON (transcript, N-best or actions alone) or multipart with an audio
  file -> the posterior, what was heard, the clarifying decision and the robot's plan.
* ``GET /v1/scenarios``, ``GET /v1/scenarios/{id}``, ``GET /v1/scenarios/{id}.png``.
* ``POST /v1/perceive``: camera frames -> world, actions and goals through a vision model.
* ``POST /v1/say``: synthesised speech, optionally with noise at an SNR -> ``audio/wav``.
* ``GET /healthz``; ``GET /openapi.json``; the API docs at ``/docs``; the web page at ``/``.
* Every request is checked (:mod:`siftom.service.access`, docs/security.md): its ``Host``
  (loopback names, IP addresses, ``settings.allowed_hosts``), the ``Origin`` of a POST, PUT,
  PATCH, DELETE or WebSocket, and with a token (``settings.token``) the token on every request
  but ``/healthz`` and the static files.
* ``/v1/sessions``: a robot's own world, streamed actions, instructions
  (:mod:`siftom.service.session_api`); ratings of a trial (:mod:`siftom.service.ratings_api`);
  ``WS /v1/sessions/{id}/listen``: streamed microphone audio, answered utterance by utterance
  (:mod:`siftom.service.stream_api`).

CPU work runs in a worker thread under a capacity limit and a time limit, so the event loop
stays responsive; the shared parts are locked in :mod:`siftom.service.runtime`.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import anyio
import anyio.to_thread
from fastapi import FastAPI, Query, Request
from fastapi import Path as PathParam
from fastapi.openapi.utils import get_openapi
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles

from siftom.api import make_instruction
from siftom.assist.clarify import ClarifyPolicy
from siftom.errors import UnknownNameError
from siftom.observer import Observer
from siftom.service.access import Access, AccessGuard, authenticated
from siftom.service.problems import (
    PROBLEM_JSON,
    BodyLimitMiddleware,
    ProblemError,
    SecurityHeadersMiddleware,
    install_handlers,
    read_audio_form,
)
from siftom.service.runtime import Runtime, ServiceSettings, default_data_dir, timeline
from siftom.service.schemas import (
    AUDIO_FORM_SCHEMA,
    MAX_SCENARIO_ID,
    AudioFields,
    InferRequest,
    InferResponse,
    Problem,
    SayRequest,
)
from siftom.settings import Settings

STATIC = Path(__file__).parent / "static"
R = TypeVar("R")


def _version() -> str:
    from siftom import __version__

    return __version__


def _problems(*codes: int) -> dict[int | str, dict[str, Any]]:
    return {c: {"model": Problem, "content": {PROBLEM_JSON: {}}} for c in codes}


def _jsonable(value: Any) -> Any:
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return str(value)


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
    rt = Runtime(settings, folder, observer, owns_dir=data_dir is None)  # a temporary folder goes on close
    app = FastAPI(title="siftom", version=_version(), docs_url=None, redoc_url=None,
                  description="Follow noisy spoken instructions by inferring what the person is doing (SIFToM).")
    app.state.runtime = rt
    install_handlers(app)
    app.add_middleware(BodyLimitMiddleware, max_bytes=settings.max_body_bytes)
    access = Access(token=settings.token, hosts=settings.allowed_hosts, origins=settings.allowed_origins)
    app.add_middleware(AccessGuard, access=access)  # Host, Origin, token: docs/security.md
    app.add_middleware(SecurityHeadersMiddleware)
    limiter: list[anyio.CapacityLimiter] = []

    async def run_cpu(fn: Callable[..., R], *args: Any) -> R:
        """Run ``fn`` in a worker thread within the request time limit (503 when it runs over)."""
        if not limiter:
            limiter.append(anyio.CapacityLimiter(settings.workers))
        rt.requests += 1
        try:
            with anyio.fail_after(settings.request_timeout_s):
                return await anyio.to_thread.run_sync(functools.partial(fn, *args), limiter=limiter[0],
                                                      abandon_on_cancel=True)
        except TimeoutError:
            raise ProblemError(503, "timeout", f"the request took longer than {settings.request_timeout_s:g} s; "
                               "try again, or send a shorter recording", headers={"Retry-After": "2"}) from None

    def lookup(sid: str, status: int) -> None:
        try:
            rt.scenario(sid)
        except UnknownNameError as exc:
            raise ProblemError(status, "unknown-scenario", str(exc)) from None

    # ----- page ------------------------------------------------------------------------------
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    @app.get("/", include_in_schema=False)
    async def index() -> FileResponse:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    @app.get("/favicon.ico", include_in_schema=False)
    async def favicon() -> FileResponse:
        return FileResponse(STATIC / "favicon.svg", media_type="image/svg+xml")

    from siftom.service.apidocs import install_docs

    install_docs(app)  # GET /docs: interactive API docs from local files, no CDN

    # ----- health ----------------------------------------------------------------------------
    # the resolved values the server runs with (siftom config show), secrets masked
    settings_view = {key: _jsonable(value) for key, value, _ in observer.settings.show()}
    settings_view["service.token"] = "set" if settings.token else None  # the one in force, never its value

    @app.get("/healthz", tags=["meta"])
    async def healthz(request: Request) -> dict[str, Any]:
        """Liveness; with the token (or on a server without one) also the version and what this
        server offers."""
        if not authenticated(request):  # open to monitors, but nothing about the server
            return {"status": "ok", "token_required": True}
        from siftom.memo import memo_stats
        from siftom.registry import load_all
        from siftom.speech.noise import SYNTHETIC_KINDS
        from siftom.speech.tts import list_voices

        return {
            "status": "ok", "version": _version(), "uptime_s": round(time.time() - rt.started, 1),
            "scenarios": len(rt.scenario_ids()), "likelihoods": list(settings.offered),
            "llm": rt.llm_status(),
            "plugins": {kind: reg.describe() for kind, reg in load_all().items()},
            "voices": [v.name for v in list_voices(available_only=True)], "noises": list(SYNTHETIC_KINDS),
            "limits": {"max_body_bytes": settings.max_body_bytes, "max_audio_seconds": settings.max_audio_seconds,
                       "request_timeout_s": settings.request_timeout_s,
                       "sessions": dataclasses.asdict(settings.sessions),
                       "stream": dataclasses.asdict(settings.stream)},
            "settings": settings_view,
            "caches": memo_stats(),  # the scorers' memos: hits, misses, size, bound
            "admission": rt.admission.stats(),  # utterances answered, in flight, degraded (admission.py)
        }

    # ----- scenarios -------------------------------------------------------------------------
    @app.get("/v1/scenarios", tags=["scenarios"])
    async def list_scenarios() -> dict[str, Any]:
        """Every registered scenario: id, domain, one-line description, number of actions."""
        def build() -> list[dict[str, Any]]:
            out = []
            for sid in rt.scenario_ids():
                sc = rt.scenario(sid)
                out.append({"id": sid, "domain": sc.domain, "description": sc.description,
                            "num_actions": len(sc.actions), "verb": sc.verb})
            return out

        return {"scenarios": await run_cpu(build)}

    sid_param = PathParam(min_length=1, max_length=MAX_SCENARIO_ID,
                          description="scenario id, e.g. kitchen-cereal-v0 or household-table-v0/3 "
                                      "(the slash may be written as %2F)")

    @app.get("/v1/scenarios/{scenario_id:path}.png", tags=["scenarios"], response_class=FileResponse,
             responses={200: {"content": {"image/png": {}}}, **_problems(404, 422)})
    async def scenario_map(scenario_id: str = sid_param,
                           command: str | None = Query(default=None, max_length=80,
                                                       description="a command to highlight, e.g. fetch(cereal)")
                           ) -> FileResponse:
        """The scenario's map when the human spoke (matplotlib PNG)."""
        lookup(scenario_id, 404)
        path = await run_cpu(rt.map_png, scenario_id, command)
        return FileResponse(path, media_type="image/png")

    @app.get("/v1/scenarios/{scenario_id:path}", tags=["scenarios"], responses=_problems(404, 422))
    async def scenario_detail(scenario_id: str = sid_param) -> dict[str, Any]:
        """A scenario: places with positions, objects, agents, actions and a step-by-step timeline."""
        lookup(scenario_id, 404)

        def build() -> dict[str, Any]:
            sc = rt.scenario(scenario_id)
            return {**sc.summary(), "verb": sc.verb, "classes": list(sc.world.classes), "timeline": timeline(sc)}

        return await run_cpu(build)

    # ----- inference -------------------------------------------------------------------------
    infer_body = {
        "required": True,
        "content": {
            "application/json": {"schema": {"$ref": "#/components/schemas/InferRequest"}},
            "multipart/form-data": {"schema": {"$ref": "#/components/schemas/AudioInferForm"}},
        },
    }

    @app.post("/v1/infer", tags=["inference"], openapi_extra={"requestBody": infer_body},
              responses={200: {"model": InferResponse}, **_problems(400, 404, 413, 415, 422, 501, 503)})
    async def infer(request: Request) -> JSONResponse:
        """Infer the robot command from the human's actions and what was heard.

        Send JSON (InferRequest) with a transcript or an N-best list, or multipart/form-data
        (AudioInferForm) with an ``audio`` file that the server transcribes first.
        """
        media = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if media == "application/json" or media.endswith("+json"):
            req = InferRequest.model_validate_json(await request.body())
            lookup(req.scenario, 422)
            policy = ClarifyPolicy(req.clarify.threshold, req.clarify.cost)

            def work() -> dict[str, Any]:
                nbest = [n.model_dump() for n in req.nbest] if req.nbest else None
                ins = make_instruction(transcript=req.transcript, nbest=nbest)
                return rt.infer(req.scenario, ins, req.mode, req.likelihood, req.n_actions, req.actions,
                                req.top, policy, req.decide)

            return JSONResponse(await run_cpu(work))
        if media == "multipart/form-data":
            return JSONResponse(await _infer_audio(request))
        raise ProblemError(415, "media-type", "send application/json (a transcript) or multipart/form-data "
                           f"(an audio file), not {media or 'no Content-Type'}")

    async def _infer_audio(request: Request) -> dict[str, Any]:
        fields, data = await read_audio_form(request, max_fields=16, max_part_size=settings.max_body_bytes)
        opts = AudioFields.model_validate(fields)
        lookup(opts.scenario, 422)
        policy = ClarifyPolicy(opts.clarify.threshold, opts.clarify.cost)
        return await run_cpu(rt.infer_audio, opts.scenario, data, opts.mode, opts.likelihood, opts.n_actions,
                             opts.asr_nbest, opts.top, policy, opts.decide)

    # ----- speech ----------------------------------------------------------------------------
    @app.post("/v1/say", tags=["speech"], response_class=Response,
              responses={200: {"content": {"audio/wav": {}}, "description": "16 kHz mono 16-bit WAV"},
                         **_problems(413, 422, 501, 503)})
    async def say(req: SayRequest) -> Response:
        """Speak an instruction with a TTS voice, optionally mixed with synthetic noise at an SNR."""
        wav = await run_cpu(rt.say, req.text, req.voice, req.rate, req.noise, req.snr, req.seed)
        return Response(wav, media_type="audio/wav",
                        headers={"Content-Disposition": 'inline; filename="say.wav"'})

    from siftom.service.perceive import install as install_perceive

    install_perceive(app, folder, run_cpu)  # POST /v1/perceive (camera frames through a vision model)

    # ----- sessions --------------------------------------------------------------------------
    from siftom.service.session_api import install_sessions, session_schemas

    mgr = install_sessions(app, rt, run_cpu)
    from siftom.service.stream_api import install_stream

    install_stream(app, rt, mgr, run_cpu)  # WS /v1/sessions/{id}/listen (streamed microphone audio)
    from siftom.service.perceive import install_session_frames

    install_session_frames(app, folder)  # POST /v1/sessions/{id}/frames (actions read from camera frames)
    from siftom.service.ratings_api import install_ratings

    install_ratings(app, rt, run_cpu)  # the /rate page and POST /v1/sessions/{id}/rating

    # ----- schema ----------------------------------------------------------------------------
    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        comps = schema.setdefault("components", {}).setdefault("schemas", {})
        js = InferRequest.model_json_schema(ref_template="#/components/schemas/{model}")
        comps.update(js.pop("$defs", {}))
        js["properties"]["likelihood"]["enum"] = ["auto", *settings.offered]
        comps["InferRequest"] = js
        form = {**AUDIO_FORM_SCHEMA, "properties": dict(AUDIO_FORM_SCHEMA["properties"])}
        form["properties"]["likelihood"] = {"type": "string", "enum": ["auto", *settings.offered], "default": "auto"}
        comps["AudioInferForm"] = form
        comps.update(session_schemas(settings.offered))
        app.openapi_schema = schema
        return schema

    app.openapi = openapi  # type: ignore[method-assign]
    return app
