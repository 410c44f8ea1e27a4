"""One open stream of ``WS /v1/sessions/{id}/listen``, from ``ready`` to its close (docs/streaming.md).

Audio comes in as binary messages and is cut into utterances by the session's
:class:`~siftom.inference.stream.StreamListener`; each utterance is answered in a worker thread
while audio keeps flowing, in the order spoken. An answer is prepared without side effects and
stored as the session's last once the end of speech is confirmed (unless an action came
meanwhile). A stream that closes cancels the utterances it has not answered.

A stream holds one of the server's ``max_streams`` slots, so it must send about real-time audio:
once the audio received lags the wall time since ``ready`` by more than the lag allowance
(:data:`~siftom.service.stream_settings.MAX_LAG_S`, or ``max_idle_s`` if less), it is closed
with 4408, whatever else it sends (a few bytes now and then do not keep a slot).
"""

from __future__ import annotations

import asyncio
import json
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fastapi import WebSocket, WebSocketDisconnect

from siftom.errors import SiftomError
from siftom.service.problems import ProblemError
from siftom.service.stream_params import PcmIn, StreamClosed, StreamCommand, StreamParams
from siftom.service.stream_settings import (
    CLOSE_BUSY,
    CLOSE_IDLE,
    CLOSE_INTERNAL,
    CLOSE_NORMAL,
    CLOSE_TOO_BIG,
    CLOSE_UNSUPPORTED,
    MAX_LAG_S,
)
from siftom.service.stream_state import StreamGone

if TYPE_CHECKING:
    from siftom.inference.stream import Decided, NoSpeech, Recognised, StreamListener
    from siftom.service.context import ServiceContext
    from siftom.service.session_records import Prepared, SessionReply
    from siftom.service.sessions import Session
    from siftom.speech.segment import Utterance

PARTIAL_EVERY_S = 1.0  # with ?partial=1, a "heard" event per second of speech


@dataclass(frozen=True)
class StreamPrepared:
    """An answer prepared (:meth:`SessionManager.prepare`), for the commit, and its admission note
    (sent as ``degraded``, never stored)."""

    prepared: Prepared
    degraded: str


@dataclass(frozen=True)
class StreamAnswer:
    """A stored answer as the stream sends it: the session's reply without ``session``, with the
    decision's ``question`` and ``declined`` and the admission note ``degraded``."""

    reply: SessionReply
    degraded: str

    def to_json(self) -> dict[str, Any]:
        out = {k: v for k, v in self.reply.to_json().items() if k != "session"}
        out["question"] = out["decision"].get("question", "") if out["action"] == "ask" else ""
        out["declined"] = out["decision"].get("declined", "")
        out["degraded"] = self.degraded
        return out


class StreamRun:
    """The stream of one connection over one session (see module doc); :meth:`run` until it ends."""

    def __init__(self, ws: WebSocket, ctx: ServiceContext, sess: Session, params: StreamParams) -> None:
        self.ws, self.ctx, self.sess, self.params = ws, ctx, sess, params
        self.sid = sess.id
        self.mgr = ctx.sessions
        self.limits = ctx.streams.limits
        self.pcm = PcmIn(params.rate, params.channels)
        self.gone = threading.Event()  # set when the stream ends: what is not answered yet is cancelled
        self._send_lock = asyncio.Lock()
        self._queue: asyncio.Queue[Utterance | None] = asyncio.Queue()
        self._waiting = 0
        self._next_partial = PARTIAL_EVERY_S
        self._partial_task: asyncio.Task[None] | None = None
        self._listener: StreamListener[StreamPrepared, StreamAnswer] | None = None
        self._recognise: Any = None
        self.max_lag_s = min(MAX_LAG_S, self.limits.max_idle_s)
        self._t0 = 0.0  # when ``ready`` was sent (event-loop clock)
        self._audio_s = 0.0  # seconds of audio received since

    # ----- answers (worker threads) ------------------------------------------------------------
    def _answer(self, rec: Recognised, utt: Utterance) -> StreamPrepared:
        """The session's answer, prepared (no side effects: it may run before the end is declared)."""
        from siftom.observer import Heard

        if self.gone.is_set():  # recognised after the stream closed: nothing more is done for it
            raise StreamGone(utt.index)
        # the stream's detector found the speech: the clip is the utterance it cut
        heard = Heard(rec.instruction, rec.transcript, None, {"asr": rec.seconds})
        # past the CPU budget the default likelihood gives way, and the answer says so
        with self.ctx.runtime.admission.slot(self.sess.options.likelihood) as slot:
            prepared = self.mgr.prepare(self.sid, rec.instruction, self.params.top, self.params.policy,
                                        heard=heard, likelihood=slot.likelihood,
                                        decide=slot.rule(self.sess.options.decide, self.ctx.runtime.observer.settings))
        return StreamPrepared(prepared, slot.reason)

    def _commit(self, prepared: StreamPrepared) -> StreamAnswer | None:
        """Store the answer as the session's last (None: the session changed since it was prepared)."""
        def still_open() -> None:  # under the session's lock: a closed stream changes nothing
            if self.gone.is_set():
                raise StreamGone(-1)

        reply = self.mgr.commit(self.sid, prepared.prepared, still_open)
        return None if reply is None else StreamAnswer(reply, prepared.degraded)

    def _respond(self, utt: Utterance) -> Decided[StreamAnswer] | NoSpeech:
        if self.gone.is_set():
            raise StreamGone(utt.index)
        assert self._listener is not None
        return self._listener.respond(utt)

    # ----- events (event loop) -----------------------------------------------------------------
    async def _send(self, obj: dict[str, Any]) -> None:
        async with self._send_lock:
            await self.ws.send_text(json.dumps(obj))

    async def _answers(self) -> None:
        """Answer the queued utterances one after the other, until the None that ends the queue."""
        while (utt := await self._queue.get()) is not None:
            try:
                await self._send((await self.ctx.streams.run_answer(self._respond, utt)).to_json())
            except ProblemError as exc:
                await self._send({"event": "error", "utterance": utt.index, "status": exc.status,
                                  "detail": exc.detail})
            except SiftomError as exc:
                await self._send({"event": "error", "utterance": utt.index, "status": 422, "detail": str(exc)})
            except Exception as exc:  # a bug in one answer: say so, keep listening
                await self._send({"event": "error", "utterance": utt.index, "status": 500,
                                  "detail": f"internal error: {type(exc).__name__}"})
            finally:
                self._waiting -= 1

    async def _heard_so_far(self, index: int, t: float, samples: Any) -> None:
        try:
            rec = await self.ctx.run_cpu(self._recognise, samples)
            await self._send({"event": "heard", "utterance": index, "partial": True, "t": round(t, 3),
                              "text": rec.text})
        except Exception:  # a partial result is only a courtesy: the final answer reports errors
            pass

    def _maybe_partial(self) -> None:
        """With ?partial=1: every PARTIAL_EVERY_S of speech, recognise what was said so far."""
        assert self._listener is not None
        now = self._listener.segmenter.current()
        if now is None:
            self._next_partial = PARTIAL_EVERY_S
            return
        index, start, samples = now
        t = self._listener.segmenter.time_s
        task = self._partial_task
        if t - start >= self._next_partial and (task is None or task.done()):
            self._next_partial = t - start + PARTIAL_EVERY_S
            self._partial_task = asyncio.create_task(self._heard_so_far(index, t, samples))

    async def _handle(self, events: list[Any]) -> None:
        from siftom.speech.segment import SpeechEnded

        if self.params.partial:
            self._maybe_partial()
        for ev in events:
            await self._send(ev.to_json())
            if isinstance(ev, SpeechEnded):
                if self._waiting >= self.limits.max_pending:
                    raise StreamClosed(CLOSE_BUSY, f"{self._waiting} utterances are waiting for their answer "
                                       f"(max_pending {self.limits.max_pending}); send audio in real time")
                self._waiting += 1
                self._queue.put_nowait(ev.utterance)

    # ----- the connection ----------------------------------------------------------------------
    async def run(self) -> None:
        """Send ``ready``, then read messages until the client ends, leaves or breaks a limit
        (:class:`StreamClosed` says how to close)."""
        from siftom.inference.stream import StreamListener
        from siftom.speech.segment import SegmentOptions

        scene = self.sess.scene
        # the observer's recognisers for this world (pocketsphinx biased to its command phrasings),
        # one per CPU of the budget, in the queue the budget sees (Runtime.stream_recogniser)
        self._recognise = await self.ctx.run_cpu(self.ctx.runtime.stream_recogniser, scene.world, scene.verb,
                                                 self.params.nbest)
        options = SegmentOptions(max_utterance_s=self.limits.max_utterance_s)
        # answered while the end of speech is confirmed, written once it is (if no action came meanwhile)
        self._listener = StreamListener(self._recognise, self._answer, options,
                                        version=lambda: self.mgr.revision(self.sid), commit=self._commit)
        worker = asyncio.create_task(self._answers())
        limits = self.limits
        await self._send({"event": "ready", "session": self.sid, "sample_rate": self.pcm.rate,
                          "channels": self.pcm.channels, "format": "s16le", "n_actions": len(self.sess.actions),
                          "limits": {"max_utterance_s": limits.max_utterance_s, "max_idle_s": limits.max_idle_s,
                                     "max_chunk_bytes": limits.max_chunk_bytes, "max_lag_s": self.max_lag_s}})
        self._t0 = asyncio.get_running_loop().time()
        try:
            await self._receive(worker)
        except StreamClosed:
            raise
        except WebSocketDisconnect:
            return
        except Exception as exc:  # a bug: say so and close rather than hang the client
            raise StreamClosed(CLOSE_INTERNAL, f"internal error: {type(exc).__name__}") from exc
        finally:
            self.gone.set()  # a closed, timed-out or taken-over stream: its unanswered utterances are cancelled
            worker.cancel()
            if self._partial_task is not None:
                self._partial_task.cancel()
            self._listener.close()

    def _lag(self) -> float:
        """Seconds the audio received lags the wall time since ``ready``."""
        return asyncio.get_running_loop().time() - self._t0 - self._audio_s

    def _lagging(self) -> StreamClosed:
        return StreamClosed(CLOSE_IDLE, f"audio {self._lag():.0f} s behind real time (at most {self.max_lag_s:g} s); "
                            "stream audio in real time, silence included")

    async def _receive(self, worker: asyncio.Task[None]) -> None:
        limits = self.limits
        while True:
            idle = limits.max_idle_s
            wait = min(idle, max(0.0, self.max_lag_s - self._lag()))  # until the slot's audio is too late
            try:
                msg = await asyncio.wait_for(self.ws.receive(), timeout=wait)
            except TimeoutError:
                if wait < idle:
                    raise self._lagging() from None
                raise StreamClosed(CLOSE_IDLE, f"nothing received for {idle:g} s (max_idle_s); "
                                   "send audio continuously, silence included") from None
            if msg["type"] == "websocket.disconnect":
                return
            data, text = msg.get("bytes"), msg.get("text")
            if data is not None:
                await self._audio(data)
                if self._lag() > self.max_lag_s:  # bytes now and then: not a stream of speech
                    raise self._lagging()
                continue
            command = StreamCommand.from_text(text)
            if command.end:
                await self._end(worker)
            await self._actions(command)

    async def _audio(self, data: bytes) -> None:
        limits, pcm = self.limits, self.pcm
        if len(data) > limits.max_chunk_bytes:
            raise StreamClosed(CLOSE_TOO_BIG, f"a message of {len(data)} bytes; send at most "
                               f"{limits.max_chunk_bytes} bytes per message")
        if len(data) % pcm.frame_bytes:
            raise StreamClosed(CLOSE_UNSUPPORTED, "16-bit PCM needs an even number of bytes per message"
                               if pcm.channels == 1 else f"16-bit PCM with {pcm.channels} channels needs "
                               f"a multiple of {pcm.frame_bytes} bytes per message (whole frames)")
        assert self._listener is not None
        self._audio_s += len(data) / pcm.frame_bytes / pcm.rate
        await self._handle(self._listener.feed(pcm.convert(data)))

    async def _end(self, worker: asyncio.Task[None]) -> None:
        """``{"type": "end"}``: answer what is left, then close normally."""
        assert self._listener is not None
        await self._handle(self._listener.feed(self.pcm.flush()))
        await self._handle(self._listener.finish())
        self._queue.put_nowait(None)
        await worker
        if self._partial_task is not None:
            await self._partial_task
        raise StreamClosed(CLOSE_NORMAL, "end of stream")

    async def _actions(self, command: StreamCommand) -> None:
        """``{"type": "actions", ...}``: append them; an ``actions`` event, or an ``error`` one."""
        try:
            command.check_lines()
            added, n = await self.ctx.run_cpu(_append, self.mgr, self.sid, list(command.actions))
            await self._send({"event": "actions", "added": added, "n_actions": n})
        except (SiftomError, ProblemError) as exc:
            await self._send({"event": "error", "status": getattr(exc, "status", 422),
                              "detail": getattr(exc, "detail", str(exc))})


def _append(mgr: Any, sid: str, lines: list[str]) -> tuple[list[str], int]:
    added: list[str] = mgr.append(sid, lines)
    return added, len(mgr.get(sid).actions)
