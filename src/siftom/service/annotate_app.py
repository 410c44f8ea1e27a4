"""The annotation page (``siftom annotate``): the human baseline (:mod:`siftom.people.annotate`).

An annotator agrees to the consent text, then gets one stimulus per page: the scene after each
observed action (not the goal), the recording, a box for what they heard and a form with the
scene's items (and counts). Endpoints: ``GET /api/annotation``, ``POST /api/annotators`` (the
answer holds the annotator's secret ``key``), ``GET /api/annotators/{key}/next``,
``GET /api/annotators/{key}/{pos}/audio.wav``, ``GET /api/annotators/{key}/{pos}/frames/{step}.png``,
``POST /api/annotators/{key}/answers``. The key is the annotator's own: with any other string
the recordings and answers are a 403.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, JSONResponse
from pydantic import BaseModel, Field

from siftom.people.annotate import AnnotateOptions, Annotation, answer_form
from siftom.people.collect import action_words
from siftom.people.stimuli import scenario_for
from siftom.service.access import Access
from siftom.service.people import Frames, page_app, png_response
from siftom.service.people import json_response as _json

KEY = PathParam(pattern=r"^[A-Za-z0-9_-]{16,100}$", description="the key POST /api/annotators gave")


class Join(BaseModel):
    annotator: str | None = Field(default=None, max_length=32)
    agree: bool
    key: str | None = Field(default=None, max_length=100, description="to continue: the key this id got before")


class Answer(BaseModel):
    position: int = Field(ge=0)
    typed: str = Field(max_length=500)
    item: str = Field(min_length=1, max_length=64)
    count: int | None = Field(default=None, ge=1, le=99)
    seconds: float | None = Field(default=None, ge=0, le=86400)


def create_annotate_app(dataset: str | Path, out: str | Path, options: AnnotateOptions,
                        access: Access | None = None) -> FastAPI:
    """The annotation page and its API over ``dataset``, writing into ``out`` (``access``: the
    Host, Origin and token checks, :mod:`siftom.service.access`)."""
    ann = Annotation(dataset, out, options)
    frames = Frames(Path(out) / ".frames")
    app, run_cpu = page_app("siftom annotate", "annotate.html", access=access)
    app.state.annotation = ann

    def _view(aid: str) -> dict[str, Any]:
        ids = ann.assignment(aid)
        pos = ann.next_position(aid)
        base = {"annotator": aid, "total": len(ids), "answered": len(ann.answered(aid))}
        if pos is None:
            return {**base, "done": True}
        sc = scenario_for(ann.stimulus_at(aid, pos))
        return {**base, "done": False, "position": pos,
                "actions": [action_words(sc.world, a, "The person") for a in sc.actions], "steps": len(sc.actions),
                "form": answer_form(sc).to_json()}

    @app.get("/api/annotation")
    async def info() -> JSONResponse:
        return _json({"consent": options.consent, "per_stimulus": options.per_stimulus,
                      "assignments": len(ann.assignments), "stimuli": len(ann.ds.stimuli)})

    @app.post("/api/annotators")
    async def join(req: Join) -> JSONResponse:
        from siftom.service.problems import ProblemError

        if not req.agree:
            raise ProblemError(422, "no-consent", "annotating needs your agreement to the text above; tick the box "
                               "to agree, or close the page to stop")
        who = await run_cpu(ann.join, req.annotator or None, req.key)
        return _json({**await run_cpu(_view, who.annotator), "key": who.key})

    async def whose(key: str) -> str:
        aid: str = await run_cpu(ann.annotator_for, key)
        return aid

    @app.get("/api/annotators/{key}/next")
    async def next_(key: str = KEY) -> JSONResponse:
        return _json(await run_cpu(_view, await whose(key)))

    @app.get("/api/annotators/{key}/{pos}/audio.wav", response_class=FileResponse)
    async def audio(pos: int, key: str = KEY) -> FileResponse:
        s = ann.stimulus_at(await whose(key), pos)
        return FileResponse(ann.ds.audio_path(s), media_type="audio/wav")

    @app.get("/api/annotators/{key}/{pos}/frames/{step}.png", response_class=FileResponse)
    async def frame(pos: int, step: int, key: str = KEY) -> FileResponse:
        sc = scenario_for(ann.stimulus_at(await whose(key), pos))
        return png_response(await run_cpu(frames.png, sc, step))

    @app.post("/api/annotators/{key}/answers", status_code=201)
    async def answer(req: Answer, key: str = KEY) -> JSONResponse:
        aid = await whose(key)
        await run_cpu(ann.answer, aid, req.position, req.typed, req.item, req.count, req.seconds)
        return _json(await run_cpu(_view, aid), status_code=201)

    return app
