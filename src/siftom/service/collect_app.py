"""The recording page (``siftom collect``): participants see each scenario and record what they
would ask the robot; recordings land in a dataset folder (:mod:`siftom.people.collect`).

Endpoints: ``GET /api/collection`` (domain, consent text, how many scenarios),
``POST /api/participants`` (agree to the consent text; the answer holds the participant's
secret ``key``), ``GET /api/prompts/{k}`` (scenario ``k``: actions, goal in words, what to ask
for), ``GET /api/prompts/{k}/frames/{step}.png``, ``POST /api/recordings`` (multipart:
``participant``, ``key``, ``index``, ``reference``, ``audio``). A recording needs the
participant's key (403 otherwise); a page started for one participant (``--participant``)
accepts no other. A participant who has a key gets it again only by sending it: agreeing again
without it is a 403 (the experimenter gives a new key with ``siftom collect --participant ID
--new-key``).
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse
from pydantic import BaseModel, Field

from siftom.people.collect import Collection, CollectOptions
from siftom.service.access import Access
from siftom.service.people import Frames, page_app, png_response
from siftom.service.people import json_response as _json
from siftom.service.problems import ProblemError, read_audio_form


class Agreement(BaseModel):
    participant: str = Field(min_length=1, max_length=32)
    agree: bool
    key: str | None = Field(default=None, max_length=100, description="the key this participant got before")


def create_collect_app(out: str | Path, options: CollectOptions, access: Access | None = None) -> FastAPI:
    """The recording page and its API, writing into the dataset folder ``out`` (``access``: the
    Host, Origin and token checks, :mod:`siftom.service.access`)."""
    coll = Collection(out, options)
    frames = Frames(Path(out) / ".frames")
    app, run_cpu = page_app("siftom collect", "collect.html", access=access)
    app.state.collection = coll

    def index_of(k: int) -> int:
        if not 0 <= k < len(coll.prompts):
            raise ProblemError(404, "no-scenario", f"there is no scenario {k}; this collection has "
                               f"{len(coll.prompts)} (0 to {len(coll.prompts) - 1})")
        return k

    def only(pid: str) -> None:
        if options.participant is not None and pid != options.participant:
            raise ProblemError(403, "participant", f"this page records participant {options.participant!r} only; "
                               "start siftom collect without --participant (or with this id) for another one")

    @app.get("/api/collection")
    async def info() -> JSONResponse:
        return _json({"domain": options.domain, "scenarios": len(coll.prompts), "consent": options.consent,
                "participant": options.participant, "max_seconds": options.max_seconds})

    @app.post("/api/participants")
    async def agree(req: Agreement) -> JSONResponse:
        if not req.agree:
            raise ProblemError(422, "no-consent", "recording needs your agreement to the text above; "
                               "tick the box to agree, or close the page to stop")
        only(req.participant)
        rec = await run_cpu(coll.agree, req.participant, req.key)
        return _json({"participant": req.participant, "key": rec.key, "done": coll.done(req.participant),
                      "scenarios": len(coll.prompts)})

    @app.get("/api/prompts/{k}")
    async def prompt(k: int) -> JSONResponse:
        return _json(coll.prompt(index_of(k)).to_json())

    @app.get("/api/prompts/{k}/frames/{step}.png", response_class=FileResponse)
    async def frame(k: int, step: int) -> FileResponse:
        sc = coll.scenario(index_of(k))
        return png_response(await run_cpu(frames.png, sc, step))

    @app.post("/api/recordings", status_code=201)
    async def record(request: Request) -> JSONResponse:
        fields, data = await read_audio_form(request, max_fields=5, max_part_size=8 * 2**20)
        try:
            k = int(fields.get("index", ""))
        except ValueError:
            raise ProblemError(422, "validation", "index: give the scenario index as a whole number") from None
        pid = fields.get("participant", "")
        only(pid)
        stim = await run_cpu(coll.save, pid, index_of(k), data, fields.get("reference", ""), fields.get("key", ""))
        return _json({"id": stim.id, "audio": stim.audio, "duration_s": stim.duration_s, "done": coll.done(pid)},
                     status_code=201)

    return app
