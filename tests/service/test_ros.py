"""The ROS bridge against a local server that speaks the rosbridge v2 protocol: a recorded action
stream and a recorded instruction in, one decision out on /siftom/decision."""

from __future__ import annotations

import base64
import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from siftom.errors import AudioError, BackendUnavailableError, OptionsError
from siftom.listener import HomeListener, load_home
from siftom.service.ros import RosBridge, RosTopics, audio_bytes, audio_message, parse_url
from support.rosbridge import FakeRosbridge
from support.streaming import pcm16, say, silence

pytest.importorskip("roslibpy", reason="needs the ros extra: pip install 'siftom[ros]'")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets")

ROOT = Path(__file__).resolve().parents[2]
FIX = ROOT / "tests" / "fixtures" / "ros"
WORLD = ROOT / "docs" / "examples" / "salad" / "world.json"
SPOKEN = "can you get me the tomato"


def _bridge(rb: FakeRosbridge, topics: RosTopics | None = None) -> tuple[RosBridge, threading.Thread, list]:
    log: list = []
    bridge = RosBridge(HomeListener(load_home(scene=WORLD)), rb.url, topics, out=lambda e: log.append(e.to_json()))
    thread = threading.Thread(target=bridge.run, daemon=True)
    thread.start()
    wanted = 1 + sum(bool(t) for t in (bridge.topics.audio, bridge.topics.text, bridge.topics.actions))
    assert rb.wait_for(lambda: len([o for o in rb.ops if o["op"] in ("subscribe", "advertise")]) >= wanted)
    return bridge, thread, log


def _decisions(robot) -> list[dict]:
    out = []
    while True:
        try:
            m = json.loads(robot.recv(timeout=0.05))
        except TimeoutError:
            return out
        if m.get("op") == "publish" and m["topic"] == "/siftom/decision":
            out.append(json.loads(m["msg"]["data"]))


def test_actions_and_an_utterance_round_trip_into_a_decision(tmp_path):
    clip = say(SPOKEN, tmp_path / "tomato.wav")
    audio = pcm16(np.concatenate([silence(0.3), clip, silence(0.8)]))
    recorded = [json.loads(ln) for ln in (FIX / "robot_publishes.jsonl").read_text().splitlines()]
    with FakeRosbridge() as rb:
        bridge, thread, log = _bridge(rb)
        try:
            # the bridge announced itself as recorded: decision publisher, actions and audio subscriber
            mine = [{k: o[k] for k in ("op", "topic", "type")} for o in rb.ops if o["op"] in ("subscribe", "advertise")]
            assert mine == json.loads((FIX / "bridge_ops.json").read_text())
            with ws_client.connect(rb.url) as robot:
                robot.send(json.dumps({"op": "subscribe", "topic": "/siftom/decision", "type": "std_msgs/String"}))
                for op in recorded:
                    if op.get("msg", {}).get("data") == "AUDIO":  # the microphone: 20 ms AudioData chunks
                        for k in range(0, len(audio), 640):
                            robot.send(json.dumps({**op, "msg": audio_message(audio[k:k + 640])}))
                            time.sleep(0.002)
                    else:
                        robot.send(json.dumps(op))
                deadline, got = time.monotonic() + 30, []
                while not got and time.monotonic() < deadline:
                    got += _decisions(robot)
                time.sleep(0.5)
                got += _decisions(robot)
        finally:
            bridge.stop()
            thread.join(10)
    assert len(got) == 1, (got, log)
    (decision,) = got
    assert decision["event"] == "decision" and decision["heard"] == SPOKEN
    assert decision["command"] == "fetch(tomato)" and decision["action"] == "act"
    steps = [e for e in log if e.get("event") == "actions"]  # one per message; a line may be 0-2 actions
    assert [e["added"] for e in steps] == [[], ["walk(human, fridge)", "open(human, fridge)"],
                                           ["grab(human, lettuce_1, fridge)"], ["walk(human, counter)", "put(human, lettuce_1, counter)"]]
    assert decision["n_actions"] == 5 == steps[-1]["n_actions"]  # every action counted before the words
    assert 0.2 < decision["start_s"] < decision["end_s"] < 0.3 + len(clip) / 16000 + 0.1


def test_a_text_topic_is_answered_as_a_transcript():
    topics = RosTopics(audio="", text="/speech/text", actions="/siftom/actions")
    with FakeRosbridge() as rb:
        bridge, thread, _ = _bridge(rb, topics)
        try:
            with ws_client.connect(rb.url) as robot:
                robot.send(json.dumps({"op": "subscribe", "topic": "/siftom/decision", "type": "std_msgs/String"}))
                robot.send(json.dumps({"op": "publish", "topic": "/speech/text", "msg": {"data": SPOKEN}}))
                got: list = []
                deadline = time.monotonic() + 20
                while not got and time.monotonic() < deadline:
                    got += _decisions(robot)
        finally:
            bridge.stop()
            thread.join(10)
    # no action seen yet: the words alone are uncertain, so the robot may wait, but it read them
    assert got and got[0]["top_command"] == "fetch(tomato)" and got[0]["n_actions"] == 0
    assert got[0]["action"] in ("act", "none")


def test_audio_data_in_either_json_form():
    pcm = pcm16(np.linspace(-0.5, 0.5, 100, dtype=np.float32))
    assert audio_bytes({"data": base64.b64encode(pcm).decode()}) == pcm
    assert audio_bytes({"data": list(pcm)}) == pcm
    wav_header = b"RIFF" + b"\0" * 4 + b"WAVE" + b"\0" * 32
    assert audio_bytes({"data": list(wav_header + pcm)}) == pcm
    for bad in ({}, {"data": "%%%"}, {"data": [300]}):
        with pytest.raises(AudioError):
            audio_bytes(bad)


def test_settings_and_connection_errors_say_how_to_fix_them():
    assert parse_url("ws://robot.local:9090") == ("robot.local", 9090, False)
    assert parse_url("robot.local") == ("robot.local", 9090, False)
    with pytest.raises(OptionsError, match="ws://HOST:9090"):
        parse_url("http://robot:9090")
    with pytest.raises(OptionsError, match="absolute ROS name"):
        RosTopics(audio="audio")
    with pytest.raises(OptionsError, match="audio topic, a text topic"):
        RosTopics(audio="", text="")
    with FakeRosbridge() as rb:
        url = rb.url
    with pytest.raises(BackendUnavailableError, match="rosbridge_server"):
        RosBridge(HomeListener(load_home(scene=WORLD)), url, connect_timeout=2)
