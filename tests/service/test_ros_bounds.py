"""The ROS bridge under a robot that sends more than it can take: the audio queue holds at most
10 s (oldest dropped first), text messages are answered by a few threads (not one per
message), and decisions wait for the decision topic to be advertised again after rosbridge
reconnects."""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from siftom.inference.stream import Decided, StreamTimings
from siftom.listener import HomeListener, load_home
from siftom.service.ros import (
    AUDIO_QUEUE_S,
    TEXT_PENDING,
    TEXT_WORKERS,
    AudioQueue,
    RosBridge,
    RosTopics,
)
from support.rosbridge import FakeRosbridge

pytest.importorskip("roslibpy", reason="needs the ros extra: pip install 'siftom[ros]'")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets")

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "docs" / "examples" / "salad" / "world.json"
SECOND = 32_000  # bytes of 16 kHz 16-bit audio


def test_the_audio_queue_holds_ten_seconds_and_drops_the_oldest():
    q = AudioQueue(AUDIO_QUEUE_S)
    chunks = [bytes([k]) * SECOND for k in range(15)]  # 15 s, one second per chunk
    dropped = sum(q.put(c) for c in chunks)
    assert dropped == pytest.approx(5.0) and q.seconds == pytest.approx(10.0)
    q.close()
    got = list(iter(q.get, None))
    assert [c[0] for c in got] == list(range(5, 15))  # the newest 10 s, in order
    q = AudioQueue(1.0)
    assert q.put(b"\x01\x00" * SECOND) == 0 and q.seconds == pytest.approx(1.0)  # a 2 s chunk: its last 1 s


def _bridge(rb: FakeRosbridge, topics: RosTopics | None = None) -> tuple[RosBridge, list]:
    log: list = []
    bridge = RosBridge(HomeListener(load_home(scene=WORLD)), rb.url, topics, out=lambda e: log.append(e.to_json()))
    assert rb.wait_for(lambda: "/siftom/decision" in rb.advertised)
    return bridge, log


def test_a_flood_of_audio_keeps_the_newest_ten_seconds():
    with FakeRosbridge() as rb:
        bridge, log = _bridge(rb)
        try:
            for k in range(15):  # nobody listens (run() not started): the queue fills
                bridge._on_audio({"data": list(bytes([k, 0]) * (SECOND // 2))})
            assert bridge._audio.seconds == pytest.approx(10.0)
            assert bridge._audio.get()[0] == 5  # the oldest kept
            assert any("dropped the oldest" in str(o.get("detail")) for o in log), log
        finally:
            bridge.stop()
            bridge._terminate()


@dataclass(frozen=True)
class _Body:
    command: str | None

    def to_json(self) -> dict:
        return {"command": self.command}


def _decided(heard: str, command: str | None) -> Decided:
    return Decided(None, heard, (), _Body(command), StreamTimings())


def test_text_messages_use_a_bounded_pool_of_threads():
    topics = RosTopics(audio="", text="/speech/text")
    with FakeRosbridge() as rb:
        bridge, log = _bridge(rb, topics)
        gate = threading.Event()
        calls: list[str] = []

        def slow(text: str) -> Decided:
            calls.append(text)
            gate.wait(10)
            return _decided(text, None)

        bridge.home.answer_text = slow  # type: ignore[method-assign]
        before = threading.active_count()
        try:
            for k in range(50):
                bridge._on_text({"data": f"bring me the tomato {k}"})
            assert threading.active_count() <= before + TEXT_WORKERS
            refused = [o for o in log if o.get("event") == "error" and "waiting" in o.get("detail", "")]
            assert len(refused) == 50 - TEXT_PENDING, log[:3]
        finally:
            gate.set()
        deadline = time.monotonic() + 10
        while len(calls) < TEXT_PENDING and time.monotonic() < deadline:
            time.sleep(0.02)
        assert len(calls) == TEXT_PENDING
        bridge.stop()
        bridge._terminate()


def test_decisions_wait_for_the_topic_to_be_advertised_again_after_a_reconnect():
    with FakeRosbridge() as rb:
        bridge, _log = _bridge(rb)
        try:
            rb.drop()  # rosbridge restarted, or the network cut for a moment
            assert rb.wait_for(lambda: not rb.advertised_by and not bridge._advertised)
            bridge.publish(_decided("can you get me the tomato", "fetch(tomato)"))
            # roslibpy reconnects by itself; the bridge advertises the topic, then publishes
            with ws_client.connect(rb.url) as robot:
                robot.send(json.dumps({"op": "subscribe", "topic": "/siftom/decision", "type": "std_msgs/String"}))
                assert rb.wait_for(lambda: any("/siftom/decision" in t for t in rb.advertised_by.values()), 30)
                assert rb.wait_for(lambda: [o for o in rb.ops if o["op"] == "publish"], 10)
                m = json.loads(robot.recv(timeout=10))
            assert json.loads(m["msg"]["data"])["command"] == "fetch(tomato)"
            assert [o for o in rb.unadvertised if o["topic"] == "/siftom/decision"] == []
        finally:
            bridge.stop()
            bridge._terminate()
