"""``POST /v1/perceive``: camera frames -> world JSON, the person's actions and a goal space.

The frames (data URLs or bare base64) and an optional known world are checked before the
vision model is asked, so bad input is a 422; a model that is not configured is a 501, one that
fails or keeps answering wrongly a 502 (docs/perception.md).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal, TypeVar

import anyio
import anyio.to_thread
from fastapi import APIRouter, Request
from fastapi import Path as PathParam
from fastapi.encoders import jsonable_encoder
from fastapi.responses import JSONResponse
from pydantic import Field

from siftom.errors import BackendUnavailableError, PerceptionError
from siftom.service.context import Ctx
from siftom.service.problems import ProblemError
from siftom.service.schemas import Strict
from siftom.service.session_schemas import SESSION_ID, ActionsResponse
from siftom.world.io import check_world_bounds

router = APIRouter()
R = TypeVar("R")
MAX_FRAMES = 32
PERCEIVE_TIMEOUT_S = 300.0  # a vision model takes tens of seconds per frame, far over the infer limit


class PerceiveRequest(Strict):
    """Frames in time order, and optionally the world at the first frame."""

    frames: list[str] = Field(min_length=1, max_length=MAX_FRAMES,
                              description="images (JPEG, PNG, WebP) as data URLs data:image/png;base64,... or base64")
    world: dict[str, Any] | None = Field(default=None, description="the known world at the first frame (siftom "
                                         "world JSON or a VirtualHome graph); then only actions and goals are asked")
    goal_space: Literal["household-table-v0", "kitchen-v0"] | None = Field(
        default=None, description="a goal library to merge with the proposed goals")
    target: str | None = Field(default=None, min_length=1, max_length=200,
                               description="the place the goals refer to (default: proposed by the model)")
    propose_goals: bool = Field(default=True, description="ask the model for goals")


def vision_model(llm: Any, folder: Path) -> Any:
    """The vision model at the server's LLM endpoint (``siftom serve --llm-base-url/--llm-model``,
    else ``SIFTOM_LLM_*``); ``SIFTOM_VLM_MODEL`` names a different model at that endpoint."""
    from siftom.perception import VisionModel
    from siftom.settings.environment import VLM_MODEL, read

    if llm is not None and llm.backend == "openai":
        return VisionModel(model=read(VLM_MODEL) or llm.model, cache_dir=folder, base_url=llm.base_url,
                           api_key=llm.api_key, timeout_s=llm.timeout_s, max_retries=llm.max_retries)
    return VisionModel(cache_dir=folder)


def _vision(ctx: Ctx) -> Any:
    """The server's vision model; a 501 when none is configured."""
    try:
        return vision_model(ctx.settings.llm, ctx.folder)
    except BackendUnavailableError as exc:
        raise ProblemError(501, "vision-model-not-configured", str(exc)) from None


async def _ask_model(work: Callable[[], R]) -> R:
    """The vision model's work in a worker thread: a 504 past PERCEIVE_TIMEOUT_S, a 502 when it fails."""
    try:
        with anyio.fail_after(PERCEIVE_TIMEOUT_S):
            return await anyio.to_thread.run_sync(work, abandon_on_cancel=True)
    except TimeoutError:
        raise ProblemError(504, "timeout", f"perception took longer than {PERCEIVE_TIMEOUT_S:g} s; send fewer "
                           "frames") from None
    except (PerceptionError, BackendUnavailableError) as exc:
        raise ProblemError(502, "vision-model-failed", str(exc)) from None


def _decoded(frames: list[str]) -> list[Any]:
    """The frames as images; a PerceptionError naming the first that is not one."""
    from siftom.perception import Frame

    return [Frame.from_data_url(f, f"frames[{k}]") for k, f in enumerate(frames)]


@router.post("/v1/perceive", tags=["perception"], response_model=dict[str, Any],
             responses={c: {"description": d} for c, d in ((422, "bad frames or world"), (501, "no vision model "
                        "configured"), (502, "the vision model failed or its answers were rejected"))})
async def perceive_route(req: PerceiveRequest, ctx: Ctx) -> JSONResponse:
    """Turn camera frames into a world, the person's actions and a goal space with a vision model."""
    from siftom.perception import perceive
    from siftom.perception.pipeline import KnownWorld

    if req.world is not None:  # a 422 at once, before anything is decoded or built
        check_world_bounds(req.world, max_items=ctx.settings.sessions.max_world_items)

    def check() -> tuple[list[Any], KnownWorld | None]:
        decoded = _decoded(req.frames)
        return decoded, (KnownWorld.from_json(req.world) if req.world is not None else None)

    try:
        frames, world = await ctx.run_cpu(check)  # decoding and the world's walking costs: off the event loop
    except PerceptionError as exc:
        raise ProblemError(422, "invalid-observation", str(exc)) from None
    model = _vision(ctx)
    result = await _ask_model(functools.partial(perceive, frames, world=world, goal_space=req.goal_space,
                                                target=req.target, propose_goals=req.propose_goals, model=model))
    return JSONResponse(jsonable_encoder(result.to_json()))


class SessionFramesRequest(Strict):
    """Consecutive camera frames of a session's world; the first shows the current state."""

    frames: list[str] = Field(min_length=2, max_length=MAX_FRAMES,
                              description="two or more images in time order (data URLs or base64); the actions "
                              "between each pair are perceived and appended to the session")


@router.post("/v1/sessions/{session_id}/frames", tags=["sessions", "perception"],
             responses={200: {"model": ActionsResponse},
                        **{c: {"description": d} for c, d in ((404, "no such session"), (422, "bad frames, or "
                           "perceived actions impossible in the session's state"), (501, "no vision model configured"),
                           (502, "the vision model failed or its answers were rejected"))}})
async def session_frames(req: SessionFramesRequest, request: Request, ctx: Ctx,
                         session_id: str = PathParam(pattern=SESSION_ID)) -> JSONResponse:
    """Frames instead of action lines: the vision model reads the person's actions between
    consecutive frames (checked against the session's world and state), and they are appended."""
    from siftom.perception.pipeline import perceive_actions
    from siftom.service.idempotency import idem_of
    from siftom.service.session_api import reply_response

    mgr = ctx.sessions
    idem = idem_of(request.headers, "frames", req)
    first = await anyio.to_thread.run_sync(mgr.replayed, session_id, idem)  # 404 before any model call
    if first is not None:
        return reply_response(first, replayed=True)
    try:
        frames = await anyio.to_thread.run_sync(_decoded, req.frames)
    except PerceptionError as exc:
        raise ProblemError(422, "invalid-observation", str(exc)) from None
    sess = await anyio.to_thread.run_sync(mgr.get, session_id)  # 404 before any model call (rebuilt off the loop)
    model = _vision(ctx)
    lines, _state = await _ask_model(functools.partial(perceive_actions, sess.scene.world, sess.online.state,
                                                       frames, model))
    # checked again at the session's state now: another producer may have added actions meanwhile;
    # the answer is the state right after these actions
    body = await anyio.to_thread.run_sync(
        functools.partial(mgr.append_reply, session_id, lines, None, idem, "perceive"))
    return reply_response(body)
