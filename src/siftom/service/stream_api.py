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
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import re
import threading
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import anyio
from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field

from siftom.assist.clarify import ClarifyPolicy
from siftom.errors import SiftomError, UnknownNameError
from siftom.service.admission import Admission
from siftom.service.idempotency import idem_of
from siftom.service.problems import ProblemError
from siftom.service.schemas import MAX_SCENARIO_ID
from siftom.service.session_api import _problems, created_response
from siftom.service.session_schemas import SESSION_ID, SessionView
from siftom.service.sessions import SessionManager
from siftom.service.stream_settings import (
    CLOSE_ALREADY_STREAMING,
    CLOSE_BAD_PARAMETER,
    CLOSE_BUSY,
    CLOSE_IDLE,
    CLOSE_INTERNAL,
    CLOSE_NORMAL,
    CLOSE_TOO_BIG,
    CLOSE_UNKNOWN_SESSION,
    CLOSE_UNSUPPORTED,
    StreamLimits,
)
from siftom.speech.audio import SAMPLE_RATE

RunCpu = Callable[..., Awaitable[Any]]
PARTIAL_EVERY_S = 1.0  # with ?partial=1, a "heard" event per second of speech
DEGRADED = "_degraded"  # a prepared answer's admission note, sent as ``degraded`` (never stored)


class StreamClosed(Exception):
    """Close the WebSocket with ``code`` and ``reason`` (at most 123 bytes)."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code, self.reason = code, reason.encode()[:123].decode(errors="ignore")


# the query parameters of WS /v1/sessions/{id}/listen (``token`` is taken out before: access.py)
QUERY_PARAMS = ("top", "threshold", "cost", "nbest", "partial", "rate", "channels", "takeover")
MAX_CHANNELS = 8
RATES = (8000, 192_000)  # the sample rates a client may declare (resampled to 16 kHz)


def _check_names(query: Any) -> None:
    """4422 naming a query parameter this endpoint does not know (a typo would go unnoticed)."""
    for name in query:
        if name not in QUERY_PARAMS:
            raise StreamClosed(CLOSE_BAD_PARAMETER, f"unknown query parameter {name[:24]!r}; "
                               f"accepted: {', '.join(QUERY_PARAMS)}")


def _number(query: Any, name: str, default: float, lo: float, hi: float, kind: type = float) -> Any:
    raw = query.get(name)
    if raw is None:
        return kind(default)
    try:
        value = kind(raw)
    except ValueError:
        raise StreamClosed(CLOSE_BAD_PARAMETER, f"{name}={raw[:24]!r} is not a number") from None
    if not lo <= value <= hi:
        raise StreamClosed(CLOSE_BAD_PARAMETER, f"{name} must be in [{lo:g}, {hi:g}], got {raw[:24]}")
    return value


def _audio_params(query: Any) -> tuple[int, int, bool]:
    """The client's sample rate and channel count (16000 and 1 when left out) and ``takeover``."""
    return (_number(query, "rate", SAMPLE_RATE, *RATES, int), _number(query, "channels", 1, 1, MAX_CHANNELS, int),
            _number(query, "takeover", 0, 0, 1, int) == 1)


class PcmIn:
    """The client's 16-bit little-endian PCM (``rate`` Hz, ``channels`` interleaved) as the 16 kHz
    mono the detector takes: channels averaged, then resampled with soxr (streaming, so chunks
    of any size join up without clicks)."""

    def __init__(self, rate: int = SAMPLE_RATE, channels: int = 1) -> None:
        import soxr

        self.rate, self.channels = rate, channels
        self.frame_bytes = 2 * channels
        self._soxr = soxr.ResampleStream(rate, SAMPLE_RATE, 1, dtype="float32") if rate != SAMPLE_RATE else None

    def convert(self, data: bytes) -> Any:
        """One binary message -> 16 kHz mono (the bytes as they are when they are that already)."""
        if self.channels == 1 and self._soxr is None:
            return data
        import numpy as np

        x = np.frombuffer(data, dtype="<i2").astype(np.float32) / 32768.0
        if self.channels > 1:
            x = x.reshape(-1, self.channels).mean(axis=1)
        return x if self._soxr is None else self._soxr.resample_chunk(x)

    def flush(self) -> Any:
        """What the resampler still holds, at the end of the stream."""
        import numpy as np

        if self._soxr is None:
            return np.zeros(0, dtype=np.float32)
        return self._soxr.resample_chunk(np.zeros(0, dtype=np.float32), last=True)


class StreamGone(Exception):
    """The stream closed before this utterance was answered: its answer is cancelled."""


@dataclass
class OpenStream:
    """One session's open stream: the task running it, and whether a newer connection took it over."""

    task: asyncio.Task[None] | None = None
    taken_over: bool = False


def _params(query: Any, top_default: int, nbest_default: int) -> tuple[int, ClarifyPolicy, int, bool]:
    """top, clarifying policy, N-best size and partial results from the query string (4422 when
    invalid or unknown); left out, top and the N-best size are the settings (infer.top, infer.nbest)."""
    _check_names(query)

    def number(name: str, default: float, lo: float, hi: float, kind: type = float) -> Any:
        return _number(query, name, default, lo, hi, kind)

    top = number("top", min(top_default, 20), 1, 20, int)
    policy = ClarifyPolicy(number("threshold", ClarifyPolicy().threshold, 0, 1),
                           number("cost", ClarifyPolicy().cost, 0, 1))
    return top, policy, number("nbest", min(nbest_default, 10), 1, 10, int), number("partial", 0, 0, 1, int) == 1


class ScenarioSession(BaseModel):
    """A session over a registered scenario's world, having seen its first ``n_actions`` actions."""

    model_config = ConfigDict(extra="forbid")
    scenario: str = Field(min_length=1, max_length=MAX_SCENARIO_ID, examples=["kitchen-cereal-v0"])
    n_actions: int | None = Field(default=None, ge=0, le=10_000,
                                  description="the scenario's recorded actions already seen (default: all)")


def scenario_spec(sc: Any) -> dict[str, Any]:
    """The world JSON of a registered scenario (its domain's doors included), for a session."""
    from siftom.world.domains import household, kitchen
    from siftom.world.io import scene_to_json

    doors = {"household-table-v0": household.DOORS, "kitchen-v0": kitchen.DOORS}.get(sc.domain)
    return {"world": scene_to_json(sc.world, sc.start, sc.goals, sc.verb, doors), "goals": None,
            "goal_space": None, "target": None}


def install_stream(app: FastAPI, rt: Any, mgr: SessionManager, run_cpu: RunCpu) -> None:
    """Add ``WS /v1/sessions/{id}/listen`` (limits: ``rt.settings.stream``) and
    ``POST /v1/sessions/from-scenario`` (a session to stream into from the web page)."""
    limits: StreamLimits = rt.settings.stream
    open_streams: dict[str, OpenStream] = {}
    app.state.streams = open_streams
    admitted = [0]  # streams past the max_streams check (counted before any await: no race)
    # one CPU budget for every stream's utterances (admission.py)
    admission: Admission = getattr(rt, "admission", None) or Admission()
    # streams wait for their answers in threads of their own: HTTP requests never queue behind them
    stream_threads = anyio.CapacityLimiter(limits.max_streams)
    timeout_s = rt.settings.request_timeout_s

    async def run_answer(fn: Callable[..., Any], *args: Any) -> Any:
        try:
            with anyio.fail_after(timeout_s):
                return await anyio.to_thread.run_sync(functools.partial(fn, *args), limiter=stream_threads,
                                                      abandon_on_cancel=True)
        except TimeoutError:
            raise ProblemError(503, "timeout", f"the answer took longer than {timeout_s:g} s") from None

    @app.post("/v1/sessions/from-scenario", tags=["sessions"], status_code=201,
              responses={201: {"model": SessionView}, **_problems(413, 422, 429, 503)})
    async def session_from_scenario(req: ScenarioSession, request: Request) -> JSONResponse:
        """Start a session over a registered scenario's world with its first ``n_actions`` actions
        already observed (the web page streams its microphone into it); a retry with the same
        Idempotency-Key returns the first answer and creates nothing."""
        idem = idem_of(request.headers, "from-scenario", req.model_dump())
        first = await run_cpu(mgr.created_reply, idem)
        if first is not None:
            return created_response(first, replayed=True)
        try:
            sc = rt.scenario(req.scenario)
        except UnknownNameError as exc:
            raise ProblemError(422, "unknown-scenario", str(exc)) from None
        n = len(sc.actions) if req.n_actions is None else req.n_actions
        if n > len(sc.actions):
            raise ProblemError(422, "n-actions", f"{req.scenario} has {len(sc.actions)} recorded actions, not {n}")

        def work() -> dict[str, Any]:
            sess = mgr.create(scenario_spec(sc), {"mode": None, "likelihood": None}, idem,
                              actions=list(sc.actions[:n]), source="scenario")
            return mgr.created(idem, mgr.view(sess))

        return created_response(await run_cpu(work))

    @app.websocket("/v1/sessions/{session_id}/listen")
    async def listen(ws: WebSocket, session_id: str) -> None:
        await ws.accept()
        if admitted[0] >= limits.max_streams:
            with contextlib.suppress(Exception):
                await ws.close(CLOSE_BUSY, f"{limits.max_streams} streams are open, the most this server "
                               "allows (--max-streams); try again later")
            return
        admitted[0] += 1
        try:
            if not re.fullmatch(SESSION_ID, session_id):
                raise StreamClosed(CLOSE_UNKNOWN_SESSION, "not a session id; create one with POST /v1/sessions")
            st = rt.observer.settings
            top, policy, nbest, partial = _params(ws.query_params, st.infer.top, st.infer.nbest)
            rate, channels, takeover = _audio_params(ws.query_params)
            old = open_streams.get(session_id)
            if old is not None and not takeover:
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
                    sess = await run_cpu(mgr.get, session_id)
                except ProblemError as exc:
                    raise StreamClosed(CLOSE_UNKNOWN_SESSION,
                                       exc.detail if exc.status == 404 else str(exc)) from None
                me.task = asyncio.create_task(_stream(ws, rt, mgr, run_cpu, sess, top, policy, nbest, limits,
                                                      partial, PcmIn(rate, channels), admission, run_answer))
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
            admitted[0] -= 1


async def _stream(ws: WebSocket, rt: Any, mgr: SessionManager, run_cpu: RunCpu, sess: Any, top: int,
                  policy: ClarifyPolicy, nbest: int, limits: StreamLimits, partial: bool = False,
                  pcm: PcmIn | None = None, admission: Admission | None = None,
                  run_answer: RunCpu | None = None) -> None:
    from siftom.inference.stream import Recognised, StreamListener, recogniser
    from siftom.observer import Heard
    from siftom.speech.segment import SegmentOptions, SpeechEnded, Utterance

    sid = sess.id
    admission = admission or Admission()
    # the observer's recogniser for this world (pocketsphinx biased to its command phrasings)
    rec_eng = await run_cpu(rt.observer.recogniser, sess.scene.world, sess.scene.verb)

    pcm = pcm or PcmIn()
    gone = threading.Event()  # set when the stream ends: what is not answered yet is cancelled

    def answer(rec: Recognised, utt: Utterance) -> dict[str, Any]:
        """The session's answer, prepared (no side effects: it may run before the end is declared)."""
        if gone.is_set():  # recognised after the stream closed: nothing more is done for it
            raise StreamGone(utt.index)
        # the stream's detector found the speech: the clip is the utterance it cut
        heard = Heard(rec.instruction, rec.transcript, None, {"asr": rec.seconds})
        # past the CPU budget the default likelihood gives way, and the answer says so
        with admission.slot(sess.options.get("likelihood")) as slot:
            body = mgr.prepare(sid, rec.instruction, top, policy, heard=heard, likelihood=slot.likelihood)
        return {**body, DEGRADED: slot.reason}

    def commit(prepared: dict[str, Any]) -> dict[str, Any] | None:
        """Store the answer as the session's last (None: the session changed since it was prepared)."""
        def still_open() -> None:  # under the session's lock: a closed stream changes nothing
            if gone.is_set():
                raise StreamGone(-1)

        body = mgr.commit(sid, {k: v for k, v in prepared.items() if k != DEGRADED}, still_open)
        if body is None:
            return None
        body = {k: v for k, v in body.items() if k != "session"}
        body["question"] = body["decision"].get("question", "") if body["action"] == "ask" else ""
        body["declined"] = body["decision"].get("declined", "")
        body["degraded"] = prepared[DEGRADED]
        return body

    options = SegmentOptions(max_utterance_s=limits.max_utterance_s)
    recognise = recogniser(rec_eng.engine, nbest, rec_eng.lock)
    # answered while the end of speech is confirmed, written once it is (if no action came meanwhile)
    listener = StreamListener(recognise, answer, options, version=lambda: mgr.revision(sid), commit=commit)
    partials: dict[str, Any] = {"next": PARTIAL_EVERY_S, "task": None}
    send_lock = asyncio.Lock()
    queue: asyncio.Queue[Utterance | None] = asyncio.Queue()
    waiting = 0

    async def send(obj: dict[str, Any]) -> None:
        async with send_lock:
            await ws.send_text(json.dumps(obj))

    async def answers() -> None:
        nonlocal waiting
        while (utt := await queue.get()) is not None:
            try:
                await send(await (run_answer or run_cpu)(respond, utt))
            except ProblemError as exc:
                await send({"event": "error", "utterance": utt.index, "status": exc.status, "detail": exc.detail})
            except SiftomError as exc:
                await send({"event": "error", "utterance": utt.index, "status": 422, "detail": str(exc)})
            except Exception as exc:  # a bug in one answer: say so, keep listening
                await send({"event": "error", "utterance": utt.index, "status": 500,
                            "detail": f"internal error: {type(exc).__name__}"})
            finally:
                waiting -= 1

    def respond(utt: Utterance) -> dict[str, Any]:
        if gone.is_set():
            raise StreamGone(utt.index)
        return listener.respond(utt)

    async def heard_so_far(index: int, t: float, samples: Any) -> None:
        try:
            rec = await run_cpu(recognise, samples)
            await send({"event": "heard", "utterance": index, "partial": True, "t": round(t, 3), "text": rec.text})
        except Exception:  # a partial result is only a courtesy: the final answer reports errors
            pass

    def maybe_partial() -> None:
        """With ?partial=1: every PARTIAL_EVERY_S of speech, recognise what was said so far."""
        now = listener.segmenter.current()
        if now is None:
            partials["next"] = PARTIAL_EVERY_S
            return
        index, start, samples = now
        t = listener.segmenter.time_s
        task = partials["task"]
        if t - start >= partials["next"] and (task is None or task.done()):
            partials["next"] = t - start + PARTIAL_EVERY_S
            partials["task"] = asyncio.create_task(heard_so_far(index, t, samples))

    async def handle(events: list[Any]) -> None:
        nonlocal waiting
        if partial:
            maybe_partial()
        for ev in events:
            await send(ev.to_json())
            if isinstance(ev, SpeechEnded):
                if waiting >= limits.max_pending:
                    raise StreamClosed(CLOSE_BUSY, f"{waiting} utterances are waiting for their answer "
                                       f"(max_pending {limits.max_pending}); send audio in real time")
                waiting += 1
                queue.put_nowait(ev.utterance)

    worker = asyncio.create_task(answers())
    await send({"event": "ready", "session": sid, "sample_rate": pcm.rate, "channels": pcm.channels,
                "format": "s16le",
                "n_actions": len(sess.actions), "limits": {"max_utterance_s": limits.max_utterance_s,
                                                          "max_idle_s": limits.max_idle_s,
                                                          "max_chunk_bytes": limits.max_chunk_bytes}})
    try:
        while True:
            try:
                msg = await asyncio.wait_for(ws.receive(), timeout=limits.max_idle_s)
            except TimeoutError:
                raise StreamClosed(CLOSE_IDLE, f"nothing received for {limits.max_idle_s:g} s (max_idle_s); "
                                   "send audio continuously, silence included") from None
            if msg["type"] == "websocket.disconnect":
                return
            data, text = msg.get("bytes"), msg.get("text")
            if data is not None:
                if len(data) > limits.max_chunk_bytes:
                    raise StreamClosed(CLOSE_TOO_BIG, f"a message of {len(data)} bytes; send at most "
                                       f"{limits.max_chunk_bytes} bytes per message")
                if len(data) % pcm.frame_bytes:
                    raise StreamClosed(CLOSE_UNSUPPORTED, "16-bit PCM needs an even number of bytes per message"
                                       if pcm.channels == 1 else f"16-bit PCM with {pcm.channels} channels needs "
                                       f"a multiple of {pcm.frame_bytes} bytes per message (whole frames)")
                await handle(listener.feed(pcm.convert(data)))
                continue
            command = _command(text)
            if command["type"] == "end":
                await handle(listener.feed(pcm.flush()))
                await handle(listener.finish())
                queue.put_nowait(None)
                await worker
                if partials["task"] is not None:
                    await partials["task"]
                raise StreamClosed(CLOSE_NORMAL, "end of stream")
            try:
                added, n = await run_cpu(_append, mgr, sid, command["actions"])
                await send({"event": "actions", "added": added, "n_actions": n})
            except (SiftomError, ProblemError) as exc:
                await send({"event": "error", "status": getattr(exc, "status", 422),
                            "detail": getattr(exc, "detail", str(exc))})
    except StreamClosed:
        raise
    except WebSocketDisconnect:
        return
    except Exception as exc:  # a bug: say so and close rather than hang the client
        raise StreamClosed(CLOSE_INTERNAL, f"internal error: {type(exc).__name__}") from exc
    finally:
        gone.set()  # a closed, timed-out or taken-over stream: its unanswered utterances are cancelled
        worker.cancel()
        if partials["task"] is not None:
            partials["task"].cancel()
        listener.close()


def _append(mgr: SessionManager, sid: str, lines: list[str]) -> tuple[list[str], int]:
    added = mgr.append(sid, lines)
    return added, len(mgr.get(sid).actions)


def _command(text: str | None) -> dict[str, Any]:
    """A text message: ``{"type": "end"}`` or ``{"type": "actions", "actions": [lines]}``."""
    from siftom.safejson import loads

    try:
        obj = loads(text or "", "a text message")  # too deep, too long a number: not a command either
    except SiftomError:
        obj = None
    if isinstance(obj, dict) and obj.get("type") == "end":
        return obj
    if (isinstance(obj, dict) and obj.get("type") == "actions" and isinstance(obj.get("actions"), list)
            and all(isinstance(a, str) for a in obj["actions"]) and len(obj["actions"]) <= 100):
        return obj
    raise StreamClosed(CLOSE_UNSUPPORTED, 'text messages are {"type": "end"} or {"type": "actions", "actions": '
                       "[lines]}; send audio as binary messages")
