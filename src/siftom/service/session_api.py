"""The session endpoints (``/v1/sessions``): :data:`router`.

* ``POST /v1/sessions``: a world (siftom world JSON or VirtualHome scene graph) and optionally a
  goal library -> 201 with the session's state and its id.
* ``POST /v1/sessions/{id}/actions``: observed actions, siftom's or VirtualHome's script format.
* ``POST /v1/sessions/{id}/instruction``: a transcript, an N-best list (JSON) or a recording
  (multipart) -> posterior, command, clarifying question when it pays, the robot's plan.
* ``GET /v1/sessions/{id}``; ``DELETE /v1/sessions/{id}``.

Every mutating request takes an ``Idempotency-Key`` header (:mod:`siftom.service.idempotency`).
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi import Path as PathParam
from fastapi.responses import JSONResponse, Response

from siftom.api import make_instruction
from siftom.assist.clarify import ClarifyPolicy
from siftom.service.context import Ctx, ServiceContext, is_json, media_type, problems
from siftom.service.idempotency import REPLAYED, Idem, idem_of
from siftom.service.problems import ProblemError, read_audio_form
from siftom.service.session_records import SessionOptions, SessionReply, SessionSpec
from siftom.service.session_schemas import (
    SESSION_ID,
    ActionsRequest,
    ActionsResponse,
    AudioInstructionFields,
    InstructionRequest,
    InstructionResponse,
    SessionCreate,
    SessionView,
)
from siftom.world.io import check_world_bounds

router = APIRouter()
SID_PARAM = PathParam(pattern=SESSION_ID, description="the id POST /v1/sessions returned")


def _need_json(request: Request) -> None:
    media = media_type(request)
    if not is_json(media):
        raise ProblemError(415, "media-type", f"send application/json, not {media or 'no Content-Type'}")


def reply_response(reply: SessionReply, replayed: bool = False) -> JSONResponse:
    """200 with a session request's answer (``replayed``: the first answer to a retried Idempotency-Key)."""
    return JSONResponse(reply.to_json(), headers={REPLAYED: "true"} if replayed else None)


def created_response(view: SessionReply, replayed: bool = False) -> JSONResponse:
    """201 with a new session's state and its Location (``replayed``: a retried Idempotency-Key's)."""
    body = view.to_json()
    headers = {"Location": f"/v1/sessions/{body['id']}", **({REPLAYED: "true"} if replayed else {})}
    return JSONResponse(body, status_code=201, headers=headers)


def _json_body(ref: str) -> dict[str, Any]:
    return {"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": f"#/components/schemas/{ref}"}}}}}


@router.post("/v1/sessions", tags=["sessions"], status_code=201, openapi_extra=_json_body("SessionCreate"),
             responses={201: {"model": SessionView}, **problems(400, 413, 415, 422, 429, 503)})
async def create_session(request: Request, ctx: Ctx) -> JSONResponse:
    """Start a session over the robot's own world (and goal library); returns its id and state."""
    _need_json(request)
    limits, mgr = ctx.settings.sessions, ctx.sessions
    body = await request.body()
    if len(body) > limits.max_world_bytes:
        raise ProblemError(413, "world-too-large",
                           f"the world is {len(body)} bytes, more than the {limits.max_world_bytes} this server "
                           "allows (--max-world-bytes); leave out nodes the robot never uses")
    req = SessionCreate.model_validate_json(body)
    check_world_bounds(req.world, max_items=limits.max_world_items)  # 422 at once, before any work
    idem = idem_of(request.headers, "create", body)
    first = await ctx.run_cpu(mgr.created_reply, idem)
    if first is not None:
        return created_response(first, replayed=True)
    ctx.runtime.check_likelihood(req.likelihood)  # 422 naming those this server offers
    spec = SessionSpec(world=req.world, goals=[g.model_dump() for g in req.goals] if req.goals else None,
                       goal_space=req.goal_space, target=req.target)
    options = SessionOptions(mode=req.mode, likelihood=req.likelihood, decide=req.decide)
    return created_response(await ctx.run_cpu(_create, ctx, spec, options, idem))


def _create(ctx: ServiceContext, spec: SessionSpec, options: SessionOptions, idem: Idem | None) -> SessionReply:
    mgr = ctx.sessions
    return mgr.created(idem, mgr.view(mgr.create(spec, options, idem)))


@router.get("/v1/sessions/{session_id}", tags=["sessions"], response_model=None,
            responses={200: {"model": SessionView}, **problems(404, 422, 503)})
async def get_session(ctx: Ctx, session_id: str = SID_PARAM) -> JSONResponse:
    """The session's state: actions so far, where everything is, the belief, the last answer."""
    mgr = ctx.sessions
    return reply_response(await ctx.run_cpu(lambda: mgr.view(mgr.get(session_id))))


@router.delete("/v1/sessions/{session_id}", tags=["sessions"], status_code=204, response_class=Response,
               responses=problems(404, 422))
async def delete_session(request: Request, ctx: Ctx, session_id: str = SID_PARAM) -> Response:
    """End the session (its stored record is deleted); a retry with the same Idempotency-Key is 204 again."""
    idem = idem_of(request.headers, "close")
    await ctx.run_cpu(ctx.sessions.delete, session_id, idem.key if idem else None)
    return Response(status_code=204)


@router.post("/v1/sessions/{session_id}/actions", tags=["sessions"], openapi_extra=_json_body("ActionsRequest"),
             responses={200: {"model": ActionsResponse}, **problems(404, 409, 413, 415, 422, 503)})
async def add_actions(request: Request, ctx: Ctx, session_id: str = SID_PARAM) -> JSONResponse:
    """Append observed actions (all or none) and update the belief incrementally."""
    _need_json(request)
    mgr = ctx.sessions
    raw = await request.body()
    req = ActionsRequest.model_validate_json(raw)
    idem = idem_of(request.headers, "actions", req)
    first = await ctx.run_cpu(mgr.replayed, session_id, idem)
    if first is not None:
        return reply_response(first, replayed=True)
    if req.executed is not None:
        lines = await ctx.run_cpu(mgr.executed_actions, session_id, req.executed)
    else:
        lines = list(req.actions or [])
    return reply_response(await ctx.run_cpu(mgr.append_reply, session_id, lines, req.after, idem))


INSTRUCTION_BODY = {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/InstructionRequest"}},
    "multipart/form-data": {"schema": {"$ref": "#/components/schemas/AudioInstructionForm"}}}}


@router.post("/v1/sessions/{session_id}/instruction", tags=["sessions"],
             openapi_extra={"requestBody": INSTRUCTION_BODY},
             responses={200: {"model": InstructionResponse}, **problems(400, 404, 413, 415, 422, 501, 503)})
async def instruction(request: Request, ctx: Ctx, session_id: str = SID_PARAM) -> JSONResponse:
    """What was heard -> posterior, chosen command, clarifying question when it pays, plan."""
    media = media_type(request)
    if is_json(media):
        return await _instruction_json(request, ctx, session_id)
    if media == "multipart/form-data":
        return await _instruction_audio(request, ctx, session_id)
    raise ProblemError(415, "media-type", "send application/json (a transcript or N-best list) or "
                       f"multipart/form-data (an audio file), not {media or 'no Content-Type'}")


async def _instruction_json(request: Request, ctx: Ctx, session_id: str) -> JSONResponse:
    mgr = ctx.sessions
    req = InstructionRequest.model_validate_json(await request.body())
    idem = idem_of(request.headers, "instruction", req)
    first = await ctx.run_cpu(mgr.replayed, session_id, idem)
    if first is not None:
        return reply_response(first, replayed=True)
    policy = ClarifyPolicy(req.clarify.threshold, req.clarify.cost)
    nbest = [n.model_dump() for n in req.nbest] if req.nbest else None
    ins = make_instruction(transcript=req.transcript, nbest=nbest)
    return reply_response(await ctx.run_cpu(mgr.instruct, session_id, ins, req.top, policy, None, idem))


async def _instruction_audio(request: Request, ctx: ServiceContext, session_id: str) -> JSONResponse:
    fields, data = await read_audio_form(request, max_fields=8, max_part_size=ctx.settings.max_body_bytes)
    opts = AudioInstructionFields.model_validate(fields)
    idem = idem_of(request.headers, "instruction-audio", {k: str(v) for k, v in fields.items()}, data)
    first = await ctx.run_cpu(ctx.sessions.replayed, session_id, idem)
    if first is not None:
        return reply_response(first, replayed=True)
    return reply_response(await ctx.run_cpu(_answer_audio, ctx, session_id, data, opts, idem))


def _answer_audio(ctx: ServiceContext, session_id: str, data: bytes, opts: AudioInstructionFields,
                  idem: Idem | None) -> SessionReply:
    rt, mgr = ctx.runtime, ctx.sessions
    sess = mgr.get(session_id)  # an unknown id fails before decoding
    x = rt.decode_audio(data)
    # voice-activity detection first (silence or noise is not words), then the observer's
    # recogniser for this world (biased to its command phrasings)
    with rt.admission.recognising():  # in the queue the CPU budget sees (admission.py)
        heard = rt.observer.hear(x, sess.scene.world, sess.scene.verb, nbest=opts.asr_nbest)
    # the server's CPU budget, shared with streams (admission.py)
    with rt.admission.slot(sess.options.likelihood) as slot:
        body = mgr.instruct(session_id, heard.instruction, opts.top, ClarifyPolicy(opts.threshold, opts.cost),
                            heard=heard, idem=idem, likelihood=slot.likelihood,
                            decide=slot.rule(sess.options.decide, rt.observer.settings))
    return SessionReply({**body.to_json(), "degraded": slot.reason})
