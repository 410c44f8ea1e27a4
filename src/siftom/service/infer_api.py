"""The inference endpoints: :data:`router`.

* ``POST /v1/infer``: JSON (transcript, N-best or actions alone) or multipart with an audio
  file -> the posterior, what was heard, the clarifying decision and the robot's plan.
* ``GET /v1/scenarios``, ``GET /v1/scenarios/{id}``, ``GET /v1/scenarios/{id}.png``.
* ``POST /v1/say``: synthesised speech, optionally with noise at an SNR -> ``audio/wav``.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request
from fastapi import Path as PathParam
from fastapi.encoders import jsonable_encoder
from fastapi.responses import FileResponse, JSONResponse, Response
from pydantic import BaseModel, ConfigDict

from siftom.api import make_instruction
from siftom.assist.clarify import ClarifyPolicy
from siftom.scenarios.base import Scenario
from siftom.service.context import (
    Ctx,
    ServiceContext,
    is_json,
    media_type,
    problems,
    service_context,
)
from siftom.service.infer_reply import InferCall, InferReply
from siftom.service.problems import ProblemError, read_audio_form
from siftom.service.schemas import (
    MAX_SCENARIO_ID,
    AudioFields,
    InferFields,
    InferRequest,
    InferResponse,
    SayRequest,
)
from siftom.world.model import AGENT_NAMES, HELD, NOTHING

router = APIRouter()

SID_PARAM = PathParam(min_length=1, max_length=MAX_SCENARIO_ID,
                      description="scenario id, e.g. kitchen-cereal-v0 or household-table-v0/3 "
                                  "(the slash may be written as %2F)")
INFER_BODY = {
    "required": True,
    "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/InferRequest"}},
        "multipart/form-data": {"schema": {"$ref": "#/components/schemas/AudioInferForm"}},
    },
}


class ScenarioRow(BaseModel):
    """One line of ``GET /v1/scenarios``."""

    model_config = ConfigDict(frozen=True)
    id: str
    domain: str
    description: str
    num_actions: int
    verb: str


def _timeline(scenario: Scenario) -> list[dict[str, Any]]:
    """Per observed step: the action that led there, where each agent is, what is where."""
    w = scenario.world
    out = []
    for t, s in enumerate(scenario.states()):
        items: dict[str, list[str]] = {}
        for i, loc in enumerate(s.item_at):
            if loc != HELD:
                items.setdefault(w.places[loc].name, []).append(w.items[i].name)
        out.append({
            "t": t,
            "action": w.format_action(scenario.actions[t - 1]) if t else None,
            "agents": {AGENT_NAMES[k]: w.places[p].name for k, p in enumerate(s.agent_at)},
            "held": {AGENT_NAMES[k]: (w.items[h].name if h != NOTHING else None) for k, h in enumerate(s.held)},
            "open": [p.name for i, p in enumerate(w.places) if p.closable and s.is_open(i)],
            "items": items,
        })
    return out


def _scenario_rows(ctx: ServiceContext) -> list[ScenarioRow]:
    rt = ctx.runtime
    rows = []
    for sid in rt.scenario_ids():
        sc = rt.scenario(sid)
        rows.append(ScenarioRow(id=sid, domain=sc.domain, description=sc.description, num_actions=len(sc.actions),
                                verb=sc.verb))
    return rows


def _scenario_json(ctx: ServiceContext, scenario_id: str) -> dict[str, Any]:
    sc = ctx.runtime.scenario(scenario_id)
    return {**sc.to_json(), "verb": sc.verb, "classes": list(sc.world.classes), "timeline": _timeline(sc)}


@router.get("/v1/scenarios", tags=["scenarios"], response_model=dict[str, Any])
async def list_scenarios(ctx: Ctx) -> JSONResponse:
    """Every registered scenario: id, domain, one-line description, number of actions."""
    rows = await ctx.run_cpu(_scenario_rows, ctx)
    return JSONResponse({"scenarios": [row.model_dump() for row in rows]})


@router.get("/v1/scenarios/{scenario_id:path}.png", tags=["scenarios"], response_class=FileResponse,
            responses={200: {"content": {"image/png": {}}}, **problems(404, 422)})
async def scenario_map(ctx: Ctx, scenario_id: str = SID_PARAM,
                       command: str | None = Query(default=None, max_length=80,
                                                   description="a command to highlight, e.g. fetch(cereal)")
                       ) -> FileResponse:
    """The scenario's map when the human spoke (matplotlib PNG)."""
    ctx.lookup(scenario_id, 404)
    path = await ctx.run_cpu(ctx.runtime.map_png, scenario_id, command)
    return FileResponse(path, media_type="image/png")


@router.get("/v1/scenarios/{scenario_id:path}", tags=["scenarios"], responses=problems(404, 422),
            response_model=dict[str, Any])
async def scenario_detail(ctx: Ctx, scenario_id: str = SID_PARAM) -> JSONResponse:
    """A scenario: places with positions, objects, agents, actions and a step-by-step timeline."""
    ctx.lookup(scenario_id, 404)
    return JSONResponse(jsonable_encoder(await ctx.run_cpu(_scenario_json, ctx, scenario_id)))


@router.post("/v1/infer", tags=["inference"], openapi_extra={"requestBody": INFER_BODY},
             responses={200: {"model": InferResponse}, **problems(400, 404, 413, 415, 422, 501, 503)})
async def infer(request: Request) -> JSONResponse:
    """Infer the robot command from the human's actions and what was heard.

    Send JSON (InferRequest) with a transcript or an N-best list, or multipart/form-data
    (AudioInferForm) with an ``audio`` file that the server transcribes first.
    """
    ctx = service_context(request)  # the app's context, without a dependency to solve per request
    media = media_type(request)
    if is_json(media):
        req = InferRequest.model_validate_json(await request.body())
        ctx.lookup(req.scenario, 422)
        reply = await ctx.run_cpu(_infer_json, ctx, req)
        return JSONResponse(reply.to_json())
    if media == "multipart/form-data":
        return JSONResponse((await _infer_audio(request, ctx)).to_json())
    raise ProblemError(415, "media-type", "send application/json (a transcript) or multipart/form-data "
                       f"(an audio file), not {media or 'no Content-Type'}")


def _call(fields: InferFields, **heard: Any) -> InferCall:
    """The validated request as the call record the runtime answers."""
    return InferCall(fields.scenario, mode=fields.mode, likelihood=fields.likelihood, rule=fields.decide,
                     n_actions=fields.n_actions, top=fields.top,
                     policy=ClarifyPolicy(fields.clarify.threshold, fields.clarify.cost), **heard)


def _infer_json(ctx: ServiceContext, req: InferRequest) -> InferReply:
    nbest = [n.model_dump() for n in req.nbest] if req.nbest else None
    ins = make_instruction(transcript=req.transcript, nbest=nbest)
    actions = tuple(req.actions) if req.actions is not None else None
    return ctx.runtime.infer(_call(req, instruction=ins, actions=actions))


async def _infer_audio(request: Request, ctx: ServiceContext) -> InferReply:
    fields, data = await read_audio_form(request, max_fields=16, max_part_size=ctx.settings.max_body_bytes)
    opts = AudioFields.model_validate(fields)
    ctx.lookup(opts.scenario, 422)
    reply: InferReply = await ctx.run_cpu(ctx.runtime.infer_audio, _call(opts, audio=data, asr_nbest=opts.asr_nbest))
    return reply


@router.post("/v1/say", tags=["speech"], response_class=Response,
             responses={200: {"content": {"audio/wav": {}}, "description": "16 kHz mono 16-bit WAV"},
                        **problems(413, 422, 501, 503)})
async def say(req: SayRequest, ctx: Ctx) -> Response:
    """Speak an instruction with a TTS voice, optionally mixed with synthetic noise at an SNR."""
    wav = await ctx.run_cpu(ctx.runtime.say, req.text, req.voice, req.rate, req.noise, req.snr, req.seed)
    return Response(wav, media_type="audio/wav", headers={"Content-Disposition": 'inline; filename="say.wav"'})
