"""``POST /v1/perceive``: camera frames -> world JSON, the person's actions and a goal space.

The frames (data URLs or bare base64) and an optional known world are checked before the
vision model is asked, so bad input is a 422; a model that is not configured is a 501, one that
fails or keeps answering wrongly a 502 (docs/perception.md).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Literal

import anyio
import anyio.to_thread
from fastapi import FastAPI
from pydantic import Field

from siftom.errors import BackendUnavailableError, PerceptionError
from siftom.service.problems import ProblemError
from siftom.service.schemas import Strict

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


def install(app: FastAPI, folder: Path) -> None:
    """Add the route; accepted answers are cached under ``folder/perception``."""

    @app.post("/v1/perceive", tags=["perception"],
              responses={c: {"description": d} for c, d in ((422, "bad frames or world"), (501, "no vision model "
                         "configured"), (502, "the vision model failed or its answers were rejected"))})
    async def perceive_route(req: PerceiveRequest) -> dict[str, Any]:
        """Turn camera frames into a world, the person's actions and a goal space with a vision model."""
        from siftom.perception import Frame, VisionModel, perceive
        from siftom.perception.pipeline import known_world

        try:
            frames = [Frame.from_data_url(f, f"frames[{k}]") for k, f in enumerate(req.frames)]
            if req.world is not None:
                known_world(req.world)
        except PerceptionError as exc:
            raise ProblemError(422, "invalid-observation", str(exc)) from None
        try:
            model = VisionModel(cache_dir=folder)
        except BackendUnavailableError as exc:
            raise ProblemError(501, "vision-model-not-configured", str(exc)) from None
        work = functools.partial(perceive, frames, world=req.world, goal_space=req.goal_space, target=req.target,
                                 propose_goals=req.propose_goals, model=model)
        try:
            with anyio.fail_after(PERCEIVE_TIMEOUT_S):
                result = await anyio.to_thread.run_sync(work, abandon_on_cancel=True)
        except TimeoutError:
            raise ProblemError(504, "timeout", f"perception took longer than {PERCEIVE_TIMEOUT_S:g} s; send fewer "
                               "frames") from None
        except (PerceptionError, BackendUnavailableError) as exc:
            raise ProblemError(502, "vision-model-failed", str(exc)) from None
        return result.to_json()
