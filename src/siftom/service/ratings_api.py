"""Ratings after a trial with a session (``/rate`` page, ``POST /v1/sessions/{id}/rating``).

After the robot acted on an instruction, the participant may rate it on the paper's three
7-point statements (:data:`siftom.people.ratings.STATEMENTS`). Each rating is one JSON line in
``DATA_DIR/ratings.jsonl`` with the session, the model it ran and the command it chose;
``siftom report RESULTS --ratings DATA_DIR/ratings.jsonl`` reports the mean per model.
"""

from __future__ import annotations

import json
import secrets
import time
from typing import Any

from fastapi import APIRouter, Request
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, JSONResponse
from pydantic import BaseModel, Field

from siftom.people.ratings import RATINGS, SCALE, STATEMENTS, session_model
from siftom.private import append_private
from siftom.service.context import Ctx, ServiceContext
from siftom.service.idempotency import REPLAYED, Idem, idem_of
from siftom.service.people import STATIC
from siftom.service.problems import PROBLEM_JSON, ProblemError
from siftom.service.session_records import SessionReply
from siftom.service.session_schemas import SESSION_ID

router = APIRouter()


class RatingRequest(BaseModel):
    """Three ratings from 1 (strongly disagree) to 7 (strongly agree), one per statement."""

    scores: list[int] = Field(min_length=len(STATEMENTS), max_length=len(STATEMENTS),
                              description="one whole number from 1 to 7 per statement, in order")
    rater: str | None = Field(default=None, max_length=32, pattern=r"^[A-Za-z0-9_-]+$",
                              description="the participant's id (optional)")
    model: str | None = Field(default=None, max_length=64, pattern=r"^[A-Za-z0-9_.+-]+$",
                              description="a label for the condition (default: the session's model, e.g. siftom)")


_PROBLEMS: dict[int | str, dict[str, Any]] = {c: {"content": {PROBLEM_JSON: {}}} for c in (404, 422)}


@router.get("/rate", include_in_schema=False)
async def page() -> FileResponse:
    return FileResponse(STATIC / "rate.html", media_type="text/html")


@router.get("/v1/ratings/statements", tags=["sessions"], response_model=dict[str, Any])
async def statements() -> JSONResponse:
    """The statements to rate after a trial and the scale."""
    return JSONResponse({"statements": list(STATEMENTS), "scale": list(SCALE),
                         "labels": {"1": "strongly disagree", "4": "neither agree nor disagree",
                                    "7": "strongly agree"}})


@router.post("/v1/sessions/{session_id}/rating", tags=["sessions"], status_code=201, responses=_PROBLEMS)
async def rate(req: RatingRequest, request: Request, ctx: Ctx,
               session_id: str = PathParam(pattern=SESSION_ID, description="the session that was rated")
               ) -> JSONResponse:
    """Store the participant's ratings of the robot in this session's last trial; a retry with
    the same Idempotency-Key returns the first answer and stores nothing."""
    lo, hi = SCALE
    if not all(lo <= x <= hi for x in req.scores):
        raise ProblemError(422, "validation", f"scores: each rating is a whole number from {lo} to {hi}")
    idem = idem_of(request.headers, "rating", req)
    rec, replayed = await ctx.run_cpu(_store_rating, ctx, session_id, req, idem)
    return JSONResponse(rec, status_code=201, headers={REPLAYED: "true"} if replayed else None)


def _store_rating(ctx: ServiceContext, session_id: str, req: RatingRequest,
                  idem: Idem | None) -> tuple[dict[str, Any], bool]:
    """Append the rating to the ratings file; its JSON and whether it was a retry's first answer."""
    mgr = ctx.sessions
    sess = mgr.get(session_id)  # an unknown id is a 404
    with ctx.ratings_lock:  # one rating written at a time (the file, and the key's first answer)
        first = mgr.replayed(session_id, idem)
        if first is not None:
            return first.to_json(), True
        last = sess.last.to_json() if sess.last is not None else {}
        mode, likelihood = sess.options.mode, sess.options.likelihood
        assert mode is not None and likelihood is not None  # resolved when the session was created
        rec = {"id": secrets.token_hex(8), "session": session_id,
               "model": req.model or session_model(mode, likelihood),
               "command": last.get("command"), "action": last.get("action"),
               "top_command": last.get("top_command"), "n_actions": len(sess.actions),
               "scores": list(req.scores), "rater": req.rater, "at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        with append_private(ctx.folder / RATINGS) as f:
            f.write(json.dumps(rec) + "\n")
        rec = {**rec, "mean": round(sum(req.scores) / len(req.scores), 3)}
        if idem is not None:
            mgr.store.put_reply(session_id, idem.key, idem.request, SessionReply(rec))
    return rec, False
