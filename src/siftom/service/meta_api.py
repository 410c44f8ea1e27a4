"""The web page, ``GET /healthz`` and the OpenAPI document: :data:`router` and :func:`openapi_for`.

``/healthz`` is open to monitors; only with the token (or on a server without one) does it say
more than that the server is up: the version, what the server offers, its limits and settings
(secrets masked), its caches and its admission counters.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

from fastapi import APIRouter, FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.openapi.utils import get_openapi
from fastapi.responses import FileResponse, JSONResponse

from siftom.service.access import authenticated
from siftom.service.context import Ctx, ServiceContext
from siftom.service.schemas import AUDIO_FORM_SCHEMA, InferRequest
from siftom.service.session_schemas import (
    AUDIO_INSTRUCTION_SCHEMA,
    ActionsRequest,
    InstructionRequest,
    SessionCreate,
)

STATIC = Path(__file__).parent / "static"

router = APIRouter()


def version() -> str:
    from siftom import __version__

    return __version__


def _jsonable(value: Any) -> Any:
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return str(value)


def settings_view(ctx_settings: Any, token: str | None) -> tuple[tuple[str, Any], ...]:
    """The resolved values the server runs with (``siftom config show``), secrets masked, and
    whether a token is in force (never its value)."""
    shown = {key: _jsonable(value) for key, value, _ in ctx_settings.show()}
    shown["service.token"] = "set" if token else None
    return tuple(shown.items())


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return FileResponse(STATIC / "index.html", media_type="text/html")


@router.get("/favicon.ico", include_in_schema=False)
async def favicon() -> FileResponse:
    return FileResponse(STATIC / "favicon.svg", media_type="image/svg+xml")


@router.get("/healthz", tags=["meta"], response_model=dict[str, Any])
async def healthz(request: Request, ctx: Ctx) -> JSONResponse:
    """Liveness; with the token (or on a server without one) also the version and what this
    server offers."""
    if not authenticated(request):  # open to monitors, but nothing about the server
        return JSONResponse({"status": "ok", "token_required": True})
    return JSONResponse(jsonable_encoder(_health(ctx)))


def _health(ctx: ServiceContext) -> dict[str, Any]:
    from siftom.memo import memo_stats
    from siftom.registry import load_all
    from siftom.speech.noise import SYNTHETIC_KINDS
    from siftom.speech.tts import list_voices

    rt, settings = ctx.runtime, ctx.settings
    return {
        "status": "ok", "version": version(), "uptime_s": round(time.time() - rt.started, 1),
        "scenarios": len(rt.scenario_ids()), "likelihoods": list(settings.offered),
        "llm": rt.llm_status().to_json(),
        "plugins": {kind: [e.to_json() for e in reg.describe()] for kind, reg in load_all().items()},
        "voices": [v.name for v in list_voices(available_only=True)], "noises": list(SYNTHETIC_KINDS),
        "limits": {"max_body_bytes": settings.max_body_bytes, "max_audio_seconds": settings.max_audio_seconds,
                   "request_timeout_s": settings.request_timeout_s,
                   "sessions": dataclasses.asdict(settings.sessions),
                   "stream": dataclasses.asdict(settings.stream)},
        "settings": dict(ctx.settings_view),
        "caches": memo_stats(),  # the scorers' memos: hits, misses, size, bound
        "admission": rt.admission.stats(),  # utterances answered, in flight, degraded (admission.py)
    }


def openapi_for(app: FastAPI, offered: tuple[str, ...]) -> Any:
    """``/openapi.json`` of ``app``, built once: the routes' schema plus the request bodies read by
    hand (JSON or multipart), with the likelihoods this server offers (``offered``)."""
    if app.openapi_schema:
        return app.openapi_schema
    schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    comps = schema.setdefault("components", {}).setdefault("schemas", {})
    js = InferRequest.model_json_schema(ref_template="#/components/schemas/{model}")
    comps.update(js.pop("$defs", {}))
    js["properties"]["likelihood"]["enum"] = ["auto", *offered]
    comps["InferRequest"] = js
    form = {**AUDIO_FORM_SCHEMA, "properties": dict(AUDIO_FORM_SCHEMA["properties"])}
    form["properties"]["likelihood"] = {"type": "string", "enum": ["auto", *offered], "default": "auto"}
    comps["AudioInferForm"] = form
    comps.update(_session_schemas(offered))
    app.openapi_schema = schema
    return schema


def _session_schemas(likelihoods: tuple[str, ...]) -> dict[str, Any]:
    """The request schemas to add to /openapi.json's components (``likelihoods``: those offered)."""
    comps: dict[str, Any] = {}
    for model in (SessionCreate, ActionsRequest, InstructionRequest):
        js = model.model_json_schema(ref_template="#/components/schemas/{model}")
        comps.update(js.pop("$defs", {}))
        comps[model.__name__] = js
    offered = ["auto", *(lk for lk in likelihoods if lk in ("phonetic", "llm"))]
    comps["SessionCreate"]["properties"]["likelihood"] = {"type": "string", "enum": offered, "default": "auto"}
    comps["AudioInstructionForm"] = AUDIO_INSTRUCTION_SCHEMA
    return comps
