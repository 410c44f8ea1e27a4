"""A ROS bridge: the robot's microphone and perception topics in, decisions out (docs/ros.md).

Talks to ``rosbridge_server`` with the rosbridge v2 JSON protocol over WebSocket (roslibpy,
asyncio transport), so nothing of ROS has to be installed next to siftom:

* **audio** (``audio_common_msgs/AudioData``, 16 kHz mono 16-bit PCM; ``data`` is a uint8 array,
  sent by rosbridge as base64 or as a list of numbers) goes through the same
  :class:`~siftom.listener.HomeListener` as ``siftom listen``: utterances are cut by the
  voice-activity detector and answered;
* **text** (``std_msgs/String``, e.g. another node's speech recogniser) is answered at once as
  the transcript of an utterance;
* **actions** (``std_msgs/String``: one or more siftom or VirtualHome script lines) update the
  posterior as they come;
* each answer is published as ``std_msgs/String`` whose ``data`` is the decision's JSON
  (``heard``, ``command``, ``prob``, ``action`` act/ask/none, ``decision``, ``question``, ``commands``,
  ``timings``) on ``/siftom/decision``.

A message that is not a JSON object (a list, a string, null), or whose ``data`` has the wrong
type, is answered with an error line and otherwise ignored: nothing a robot sends stops the bridge.
Text and action lines are capped as over HTTP: a text of more than
:data:`~siftom.service.schemas.MAX_TEXT_CHARS` characters, an action line longer than that or an
actions message of more than :data:`~siftom.service.session_schemas.MAX_ACTIONS_PER_REQUEST`
lines is refused with an error line, before any work.

Bounded, whatever the robot sends: the audio waiting for the listener is at most
:data:`AUDIO_QUEUE_S` seconds (the oldest is dropped first, with an error line); text messages
are answered by :data:`TEXT_WORKERS` threads with at most :data:`TEXT_PENDING` waiting (more
are dropped with an error line). A decision is published only while the decision topic is
advertised on the current rosbridge connection: after a reconnect the bridge advertises it
again first, and the decisions made meanwhile (the last :data:`HELD_DECISIONS`) follow.
"""

from __future__ import annotations

import base64
import contextlib
import json
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlparse

import numpy as np

from siftom.errors import AudioError, BackendUnavailableError, OptionsError, SiftomError
from siftom.inference.stream import Decided, NoSpeech
from siftom.listener import (
    ActionsObserved,
    Compact,
    HomeListener,
    ListenerError,
    ListenEvent,
    run_listener,
)

BridgeLine = ListenEvent | Compact  # a line of the bridge's log: an event, or a decision as published

AUDIO_QUEUE_S = 10.0  # seconds of audio waiting for the listener at most (docs/ros.md)
TEXT_WORKERS = 2  # threads answering text messages
TEXT_PENDING = 8  # text messages waiting for them at most
HELD_DECISIONS = 50  # decisions kept while the decision topic is not advertised
SHOWN_CHARS = 80  # of a refused text, in its error line


class AudioQueue:
    """16 kHz 16-bit audio chunks waiting for the listener, at most ``max_seconds`` of audio:
    when more arrives the oldest is dropped (the listener fell behind; recent speech matters most)."""

    def __init__(self, max_seconds: float = AUDIO_QUEUE_S, rate: int = 16_000) -> None:
        self.max_bytes = max(2, int(max_seconds * rate) * 2)
        self.bytes_per_s = 2 * rate
        self._chunks: deque[bytes] = deque()
        self._bytes = 0
        self._closed = False
        self._cond = threading.Condition()

    @property
    def seconds(self) -> float:
        """Seconds of audio waiting."""
        with self._cond:
            return self._bytes / self.bytes_per_s

    def put(self, chunk: bytes) -> float:
        """Queue ``chunk``; returns the seconds of the oldest audio dropped to make room."""
        if len(chunk) > self.max_bytes:  # one chunk longer than the queue: its end
            chunk = chunk[len(chunk) - self.max_bytes:]
        dropped = 0
        with self._cond:
            self._chunks.append(chunk)
            self._bytes += len(chunk)
            while self._bytes > self.max_bytes:
                old = self._chunks.popleft()
                self._bytes -= len(old)
                dropped += len(old)
            self._cond.notify()
        return dropped / self.bytes_per_s

    def get(self) -> bytes | None:
        """The oldest chunk (blocks); None once closed and empty."""
        with self._cond:
            while not self._chunks and not self._closed:
                self._cond.wait()
            if not self._chunks:
                return None
            chunk = self._chunks.popleft()
            self._bytes -= len(chunk)
            return chunk

    def close(self) -> None:
        """No more audio: :meth:`get` returns what is queued, then None."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()


@dataclass(frozen=True)
class RosTopics:
    """Topic names and message types (``siftom ros --audio-topic ...``; remap to your robot's).

    Attributes:
        audio: the microphone topic ('' to not subscribe); ``audio_type`` its message type.
        text: a topic of recognised text ('' to not subscribe); ``text_type`` its message type.
        actions: the person's actions, one or more script lines per message ('' to not subscribe).
        decision: where each decision is published.
    """

    audio: str = "/audio/audio"
    audio_type: str = "audio_common_msgs/AudioData"
    text: str = ""
    text_type: str = "std_msgs/String"
    actions: str = "/siftom/actions"
    actions_type: str = "std_msgs/String"
    decision: str = "/siftom/decision"
    decision_type: str = "std_msgs/String"

    def __post_init__(self) -> None:
        for name in ("audio", "text", "actions", "decision"):
            topic = getattr(self, name)
            if topic and not topic.startswith("/"):
                raise OptionsError(f"the {name} topic must be an absolute ROS name such as /{topic}")
        if not self.decision:
            raise OptionsError("the decision topic cannot be empty")
        if not (self.audio or self.text):
            raise OptionsError("subscribe to an audio topic, a text topic or both")


def parse_url(url: str) -> tuple[str, int, bool]:
    """``ws://HOST:PORT`` -> (host, port, secure); rosbridge's port 9090 by default."""
    u = urlparse(url if "://" in url else f"ws://{url}")
    if u.scheme not in ("ws", "wss") or not u.hostname:
        raise OptionsError(f"--rosbridge must look like ws://HOST:9090, not {url!r}")
    return u.hostname, u.port or 9090, u.scheme == "wss"


def audio_bytes(msg: Mapping[str, object]) -> bytes:
    """The PCM bytes of an AudioData message: ``data`` as base64 text or a list of 0-255 numbers;
    a WAV header at the start of a chunk is skipped."""
    data = msg.get("data")
    if isinstance(data, str):
        try:
            raw = base64.b64decode(data, validate=True)
        except ValueError:
            raise AudioError("AudioData.data is neither base64 nor a list of bytes") from None
    elif isinstance(data, list):
        try:
            raw = bytes(data)
        except (TypeError, ValueError):
            raise AudioError("AudioData.data must hold numbers 0-255") from None
    else:
        raise AudioError("an AudioData message needs a 'data' field (uint8 array)")
    if raw[:4] == b"RIFF" and raw[8:12] == b"WAVE":
        raw = raw[44:]
    return raw[: len(raw) - len(raw) % 2]


class RosBridge:
    """Subscribe, listen, publish (see module doc). ``run()`` blocks until :meth:`stop`."""

    def __init__(self, home: HomeListener, url: str, topics: RosTopics | None = None,
                 out: Callable[[BridgeLine], None] | None = None, connect_timeout: float = 10.0) -> None:
        try:
            import roslibpy
        except ModuleNotFoundError:
            raise BackendUnavailableError('the ROS bridge needs roslibpy: pip install "siftom[ros]"') from None
        self.home, self.topics, self.url = home, topics or RosTopics(), url
        self._out = out or (lambda obj: print(json.dumps(obj.to_json()), file=sys.stderr, flush=True))
        host, port, secure = parse_url(url)
        self._roslibpy = roslibpy
        self.ros = roslibpy.Ros(host=host, port=port, is_secure=secure, transport="asyncio")
        try:
            self.ros.run(timeout=connect_timeout)
        except Exception as exc:
            self._terminate()
            raise BackendUnavailableError(f"cannot reach rosbridge at {url} ({type(exc).__name__}); start it on "
                                          "the robot: ros2 launch rosbridge_server rosbridge_websocket_launch.xml "
                                          "(ROS 1: roslaunch rosbridge_server rosbridge_websocket.launch)") from None
        self._audio = AudioQueue(AUDIO_QUEUE_S)
        self._dropped = [0.0, 0.0]  # seconds of audio dropped and not reported yet, when last reported
        self._texts = ThreadPoolExecutor(TEXT_WORKERS, thread_name_prefix="siftom-ros-text")
        self._text_pending = 0
        self._lock = threading.Lock()
        self.published: list[Compact] = []
        self._held: deque[Compact] = deque(maxlen=HELD_DECISIONS)
        self._advertised = False  # the decision topic, on the current connection
        t = self.topics
        # advertised again by this bridge on every (re)connection, before any decision is published
        self._decision = roslibpy.Topic(self.ros, t.decision, t.decision_type, reconnect_on_close=False)
        self.ros.on("close", self._on_close)
        self.ros.on("ready", self._on_ready)
        self._advertise()
        self._subs = []
        for name, typ, cb in ((t.actions, t.actions_type, self._on_actions), (t.text, t.text_type, self._on_text),
                              (t.audio, t.audio_type, self._on_audio)):
            if name:
                topic = roslibpy.Topic(self.ros, name, typ, queue_length=0)
                topic.subscribe(cb)
                self._subs.append(topic)

    # ----- callbacks (roslibpy's thread) ----------------------------------------------------
    def _text_data(self, msg: Any, topic: str) -> str | None:
        """The ``data`` text of a ``std_msgs/String`` message; None (and an error line) when ``msg``
        is not one."""
        data = msg.get("data", "") if isinstance(msg, Mapping) else None
        if not isinstance(data, str):
            got = type(msg).__name__ if not isinstance(msg, Mapping) else f"data of type {type(data).__name__}"
            self._out(ListenerError(f"ignored a message on {topic} that is not a std_msgs/String ({got}); "
                                    "publish std_msgs/String messages there", topic=topic))
            return None
        return data

    def _on_actions(self, msg: Any) -> None:
        from siftom.service.schemas import MAX_TEXT_CHARS
        from siftom.service.session_schemas import MAX_ACTIONS_PER_REQUEST

        data = self._text_data(msg, self.topics.actions)
        if data is None:
            return
        topic = self.topics.actions
        if len(data) > MAX_ACTIONS_PER_REQUEST * (MAX_TEXT_CHARS + 1):  # refused before it is even split
            self._out(ListenerError(f"ignored a message of {len(data)} characters on {topic}: send at most "
                                    f"{MAX_ACTIONS_PER_REQUEST} action lines of at most {MAX_TEXT_CHARS} characters "
                                    "per message", topic=topic))
            return
        lines = [ln.strip() for ln in data.splitlines() if ln.strip() and not ln.startswith("#")]
        long = next((k for k, ln in enumerate(lines) if len(ln) > MAX_TEXT_CHARS), None)
        if len(lines) > MAX_ACTIONS_PER_REQUEST or long is not None:
            what = (f"{len(lines)} action lines" if long is None
                    else f"an action line of {len(lines[long])} characters (line {long + 1})")
            self._out(ListenerError(f"ignored a message on {topic} with {what}: send at most "
                                    f"{MAX_ACTIONS_PER_REQUEST} lines of at most {MAX_TEXT_CHARS} characters per "
                                    "message, as over HTTP", topic=topic))
            return
        try:
            added = self.home.observe(lines)
            self._out(ActionsObserved(tuple(added), len(self.home.actions)))
        except SiftomError as exc:
            self._out(ListenerError(str(exc), actions=tuple(lines)))

    def _on_text(self, msg: Any) -> None:
        from siftom.service.schemas import MAX_TEXT_CHARS

        data = self._text_data(msg, self.topics.text)
        text = (data or "").strip()
        if not text:
            return
        if len(text) > MAX_TEXT_CHARS:  # a sentence, not a paragraph: refused before any work
            self._out(ListenerError(f"ignored a text of {len(text)} characters on {self.topics.text}: an "
                                    f"instruction has at most {MAX_TEXT_CHARS} characters, as over HTTP; send "
                                    "one utterance per message", heard=text[:SHOWN_CHARS] + "…"))
            return
        with self._lock:
            busy = self._text_pending >= TEXT_PENDING
            if not busy:
                self._text_pending += 1
        if busy:
            self._out(ListenerError(f"{TEXT_PENDING} text messages are waiting for their answer: dropped this "
                                    "one; send one per utterance", heard=text))
            return
        try:
            self._texts.submit(self._answer_text, text)
        except RuntimeError:  # stopping
            with self._lock:
                self._text_pending -= 1

    def _answer_text(self, text: str) -> None:
        try:
            self.publish(self.home.answer_text(text))
        except SiftomError as exc:  # e.g. the acoustic likelihood, which needs the audio
            self._out(ListenerError(str(exc), heard=text))
        finally:
            with self._lock:
                self._text_pending -= 1

    def _on_audio(self, msg: Any) -> None:
        if not isinstance(msg, Mapping):
            topic = self.topics.audio
            self._out(ListenerError(f"ignored a message on {topic} that is not an audio_common_msgs/AudioData "
                                    f"({type(msg).__name__}); publish AudioData (16 kHz mono 16-bit PCM) there",
                                    topic=topic))
            return
        try:
            chunk = audio_bytes(msg)
        except AudioError as exc:
            self._out(ListenerError(str(exc)))
            return
        dropped = self._audio.put(chunk)  # the listener fell behind: the oldest audio goes, ROS never waits
        if dropped:
            self._dropped[0] += dropped
            now = time.monotonic()
            if now - self._dropped[1] >= 1.0:  # one line a second at most
                self._out(ListenerError(f"audio queue full ({AUDIO_QUEUE_S:g} s): dropped the oldest "
                                        f"{self._dropped[0]:.2f} s"))
                self._dropped[:] = [0.0, now]

    # ----- decisions ---------------------------------------------------------------------------
    def _advertise(self) -> None:
        """Advertise the decision topic on this connection, then publish what was held meanwhile."""
        self._decision.advertise()  # sent before anything queued after it
        with self._lock:
            self._advertised = True
            held = list(self._held)
            self._held.clear()
        for body in held:
            self._send(body)

    def _on_ready(self, *_: Any) -> None:  # a reconnection (the first connection was made in __init__)
        with contextlib.suppress(Exception):
            self._advertise()

    def _on_close(self, *_: Any) -> None:  # the connection dropped: hold decisions until re-advertised
        with self._lock:
            self._advertised = False

    def _send(self, body: Compact) -> None:
        self._decision.publish(self._roslibpy.Message({"data": json.dumps(body.to_json())}))

    def publish(self, answer: ListenEvent) -> None:
        """Publish an answer (decision or no_speech) on the decision topic and log it (any other
        event is only logged); while the topic is not advertised (rosbridge reconnecting) it is
        held and published after."""
        body = Compact(answer)
        send = isinstance(answer, Decided | NoSpeech)
        with self._lock:
            self.published.append(body)
            if send and not self._advertised:
                self._held.append(body)
                send = False
        self._out(body)
        if send:
            self._send(body)

    def _chunks(self) -> Iterator[bytes]:
        while (chunk := self._audio.get()) is not None:
            yield chunk

    def run(self) -> None:
        """Listen until :meth:`stop` (or Ctrl-C)."""
        try:
            run_listener(self.home, self._chunks(), self.publish, realtime=True)
        finally:
            self._terminate()

    def stop(self) -> None:
        self._audio.close()

    def _terminate(self) -> None:
        if hasattr(self, "_texts"):
            self._texts.shutdown(wait=False, cancel_futures=True)
        with contextlib.suppress(Exception):  # closing a connection that is already gone
            for topic in getattr(self, "_subs", []):
                topic.unsubscribe()
            if hasattr(self, "_decision"):
                self._decision.unadvertise()
            self.ros.close()
        with contextlib.suppress(Exception):
            self.ros.terminate()


def audio_message(pcm: bytes) -> dict[str, str]:
    """An ``audio_common_msgs/AudioData`` message as rosbridge sends it (``data`` in base64)."""
    return {"data": base64.b64encode(pcm).decode()}


def pcm16(x: np.ndarray) -> bytes:
    pcm: bytes = (np.clip(x, -1.0, 1.0) * 32767).astype("<i2").tobytes()
    return pcm
