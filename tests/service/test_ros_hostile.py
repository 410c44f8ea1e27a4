"""The ROS bridge under messages that are not what their topic says: a list, a string, null or a
number in place of the message, or a ``data`` of the wrong type, is ignored with an error line;
the handlers never raise and the bridge goes on answering."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from siftom.listener import HomeListener, load_home
from siftom.service.ros import RosBridge, RosTopics
from support.rosbridge import FakeRosbridge

pytest.importorskip("roslibpy", reason="needs the ros extra: pip install 'siftom[ros]'")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets")

WORLD = Path(__file__).resolve().parents[2] / "docs" / "examples" / "salad" / "world.json"
NOT_MESSAGES: list[Any] = [[1, 2, 3], "bring me the tomato", None, 42, 3.5, True, [{"data": "x"}]]
BAD_DATA: list[Any] = [{"data": [1, 2]}, {"data": None}, {"data": {"a": 1}}, {"data": 7}]


@pytest.fixture
def bridge():
    topics = RosTopics(text="/speech/text")
    with FakeRosbridge() as rb:
        log: list[dict[str, Any]] = []
        b = RosBridge(HomeListener(load_home(scene=WORLD)), rb.url, topics, out=lambda e: log.append(e.to_json()))
        assert rb.wait_for(lambda: "/siftom/decision" in rb.advertised)
        b.test_log = log  # type: ignore[attr-defined]
        b.test_rb = rb  # type: ignore[attr-defined]
        try:
            yield b
        finally:
            b.stop()
            b._terminate()


def _errors(log: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [o for o in log if o.get("event") == "error"]


def test_a_message_that_is_not_an_object_is_ignored_with_an_error_line(bridge):
    log = bridge.test_log
    for msg in NOT_MESSAGES:
        for handler, topic in ((bridge._on_actions, "/siftom/actions"), (bridge._on_text, "/speech/text"),
                               (bridge._on_audio, "/audio/audio")):
            before = len(_errors(log))
            handler(msg)  # never raises
            new = _errors(log)[before:]
            assert len(new) == 1, (msg, topic, log)
            assert topic in new[0]["detail"] and "ignored" in new[0]["detail"]
    assert bridge.home.actions == [] and bridge._audio.seconds == 0 and bridge._text_pending == 0


def test_a_string_message_whose_data_is_not_text_is_ignored(bridge):
    log = bridge.test_log
    for msg in BAD_DATA:
        bridge._on_actions(msg)
        bridge._on_text(msg)
    errors = _errors(log)
    assert len(errors) == 2 * len(BAD_DATA) and all("std_msgs/String" in e["detail"] for e in errors), log
    assert bridge.home.actions == [] and bridge._text_pending == 0


def test_the_bridge_goes_on_after_hostile_messages_over_the_wire(bridge):
    rb, log = bridge.test_rb, bridge.test_log
    with ws_client.connect(rb.url) as robot:
        for msg in (*NOT_MESSAGES, {"data": "[Walk] <kitchen> (1)"}):
            robot.send(json.dumps({"op": "publish", "topic": "/siftom/actions", "msg": msg}))
        assert rb.wait_for(lambda: any(o.get("event") == "actions" for o in log), 10), log
    assert len(_errors(log)) == len(NOT_MESSAGES)
    steps = [o for o in log if o.get("event") == "actions"]
    assert len(steps) == 1 and steps[0]["n_actions"] == len(bridge.home.actions)
