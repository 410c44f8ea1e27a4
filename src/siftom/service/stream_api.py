"""``WS /v1/sessions/{id}/listen``: a session's microphone, streamed (docs/streaming.md).

The client sends 16-bit little-endian PCM as binary messages of any size (16 kHz mono, or the
``rate`` and ``channels`` it declares in the query: averaged and resampled here); the server cuts utterances with the voice-activity detector (:class:`~siftom.inference.stream.StreamListener`)
and sends JSON text events: ``ready``, ``speech_started``, ``speech_ended``, then ``decision``
(the session's posterior with the actions observed so far, and ``act`` / ``ask`` / ``wait``) or
``no_speech`` for each utterance; ``actions`` after an ``{"type": "actions"}`` command;
``error`` when one utterance could not be answered; with ``?partial=1`` also ``heard`` (the words
so far, once per second of speech). Recognition and inference run in worker
threads, so audio keeps flowing while an utterance is answered, and actions posted to
``/v1/sessions/{id}/actions`` meanwhile count for the next answer. One stream per session: a
second is refused with 4409 unless it asks ``takeover=1`` (the newest connection then wins);
an open stream keeps its session from expiring; a stream that closes without ``end`` cancels
the utterances it has not answered.

Also ``POST /v1/sessions/from-scenario``: a session over a registered scenario, for the web
page to stream into. The parts: :mod:`~siftom.service.stream_params` (what the client declares),
:mod:`~siftom.service.stream_state` (the open streams), :mod:`~siftom.service.stream_run` (one
stream's loop).
"""

from __future__ import annotations

import asyncio
import contextlib
import re
from typing import Any

from fastapi import APIRouter, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field

from siftom.service.context import Ctx, ServiceContext, problems
from siftom.service.idempotency import Idem, idem_of
from siftom.service.problems import ProblemError
from siftom.service.schemas import MAX_SCENARIO_ID
from siftom.service.session_api import created_response
from siftom.service.session_records import SessionOptions, SessionReply, SessionSpec
from siftom.service.session_schemas import SESSION_ID, SessionView
from siftom.service.stream_params import StreamClosed, StreamParams
from siftom.service.stream_run import StreamRun
from siftom.service.stream_settings import (
    CLOSE_ALREADY_STREAMING,
    CLOSE_BUSY,
    CLOSE_INTERNAL,
    CLOSE_UNKNOWN_SESSION,
)
from siftom.service.stream_state import OpenStream

router = APIRouter()


class ScenarioSession(BaseModel):
    """A session over a registered scenario's world, having seen its first ``n_actions`` actions."""

    model_config = ConfigDict(extra="forbid")
    scenario: str = Field(min_length=1, max_length=MAX_SCENARIO_ID, examples=["kitchen-cereal-v0"])
    n_actions: int | None = Field(default=None, ge=0, le=10_000,
                                  description="the scenario's recorded actions already seen (default: all)")


def scenario_spec(sc: Any) -> SessionSpec:
    """A registered scenario's world (its domain's doors included), for a session."""
    from siftom.world.domains import household, kitchen
    from siftom.world.io import scene_to_json

    doors = {"household-table-v0": household.DOORS, "kitchen-v0": kitchen.DOORS}.get(sc.domain)
    return SessionSpec(world=scene_to_json(sc.world, sc.start, sc.goals, sc.verb, doors))


@router.post("/v1/sessions/from-scenario", tags=["sessions"], status_code=201,
             responses={201: {"model": SessionView}, **problems(413, 422, 429, 503)})
async def session_from_scenario(req: ScenarioSession, request: Request, ctx: Ctx) -> JSONResponse:
    """Start a session over a registered scenario's world with its first ``n_actions`` actions
    already observed (the web page streams its microphone into it); a retry with the same
    Idempotency-Key returns the first answer and creates nothing."""
    mgr = ctx.sessions
    idem = idem_of(request.headers, "from-scenario", req)
    first = await ctx.run_cpu(mgr.created_reply, idem)
    if first is not None:
        return created_response(first, replayed=True)
    ctx.lookup(req.scenario, 422)
    sc = ctx.runtime.scenario(req.scenario)
    n = len(sc.actions) if req.n_actions is None else req.n_actions
    if n > len(sc.actions):
        raise ProblemError(422, "n-actions", f"{req.scenario} has {len(sc.actions)} recorded actions, not {n}")
    return created_response(await ctx.run_cpu(_create, ctx, sc, n, idem))


def _create(ctx: ServiceContext, sc: Any, n: int, idem: Idem | None) -> SessionReply:
    mgr = ctx.sessions
    sess = mgr.create(scenario_spec(sc), SessionOptions(), idem, actions=list(sc.actions[:n]), source="scenario")
    return mgr.created(idem, mgr.view(sess))


@router.websocket("/v1/sessions/{session_id}/listen")
async def listen(ws: WebSocket, session_id: str, ctx: Ctx) -> None:
    await ws.accept()
    streams = ctx.streams
    if streams.admitted >= streams.limits.max_streams:
        with contextlib.suppress(Exception):
            await ws.close(CLOSE_BUSY, f"{streams.limits.max_streams} streams are open, the most this server "
                           "allows (--max-streams); try again later")
        return
    streams.admitted += 1
    try:
        await _open(ws, ctx, session_id)
    except StreamClosed as exc:
        with contextlib.suppress(Exception):
            await ws.close(exc.code, exc.reason)
    except WebSocketDisconnect:
        pass
    except ProblemError as exc:  # e.g. building the recogniser ran over the time limit (503)
        code = CLOSE_BUSY if exc.status == 503 else CLOSE_INTERNAL
        with contextlib.suppress(Exception):
            await ws.close(code, StreamClosed(code, exc.detail).reason)
    finally:
        streams.admitted -= 1


async def _open(ws: WebSocket, ctx: ServiceContext, session_id: str) -> None:
    """Check the request, claim the session's stream (or take it over) and run it to its end."""
    if not re.fullmatch(SESSION_ID, session_id):
        raise StreamClosed(CLOSE_UNKNOWN_SESSION, "not a session id; create one with POST /v1/sessions")
    st = ctx.runtime.observer.settings
    params = StreamParams.from_query(ws.query_params, st.infer.top, st.infer.nbest)
    open_streams, mgr = ctx.streams.open, ctx.sessions
    old = open_streams.get(session_id)
    if old is not None and not params.takeover:
        raise StreamClosed(CLOSE_ALREADY_STREAMING, "this session is already streaming; close the "
                           "other stream first, or reconnect with ?takeover=1 to replace it")
    if old is not None:  # the robot again, after a frozen connection: the newest one wins
        old.taken_over = True
        if old.task is not None:
            old.task.cancel()
    me = open_streams[session_id] = OpenStream()  # before any await: a second stream is refused
    mgr.hold(session_id)  # an open stream is use: the session does not expire under it
    try:
        try:
            sess = await ctx.run_cpu(mgr.get, session_id)
        except ProblemError as exc:
            raise StreamClosed(CLOSE_UNKNOWN_SESSION, exc.detail if exc.status == 404 else str(exc)) from None
        me.task = asyncio.create_task(StreamRun(ws, ctx, sess, params).run())
        try:
            await me.task
        except asyncio.CancelledError:
            if not me.taken_over:
                raise
            raise StreamClosed(CLOSE_ALREADY_STREAMING, "another connection took this session's stream "
                               "over (takeover=1)") from None
    finally:
        mgr.release(session_id)
        if open_streams.get(session_id) is me:
            del open_streams[session_id]
