"""The ROS bridge caps text and action lines as HTTP does (``MAX_TEXT_CHARS`` characters, at most
``MAX_ACTIONS_PER_REQUEST`` lines): a 300 KB ``std_msgs/String`` on the text topic used to cost
a minute of CPU and a megabyte silenced the bridge; now each is refused at once with an error
line naming the limit, and the next instruction is answered as usual."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from siftom.listener import HomeListener, load_home
from siftom.service.ros import RosBridge, RosTopics
from siftom.service.schemas import MAX_TEXT_CHARS
from siftom.service.session_schemas import MAX_ACTIONS_PER_REQUEST
from support.rosbridge import FakeRosbridge

pytest.importorskip("roslibpy", reason="needs the ros extra: pip install 'siftom[ros]'")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets")

WORLD = Path(__file__).resolve().parents[2] / "docs" / "examples" / "salad" / "world.json"


@pytest.fixture(scope="module")
def shared():
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


@pytest.fixture
def bridge(shared):
    """The module's bridge (one start and stop: stopping takes seconds), its log emptied."""
    shared.test_log.clear()
    yield shared
    time.sleep(0.05)  # a text being answered finishes before the next test


def _errors(log: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [o for o in log if o.get("event") == "error"]


@pytest.mark.parametrize("size", [MAX_TEXT_CHARS + 1, 300_000, 1_000_000])
def test_a_long_text_is_refused_at_once_without_being_answered(bridge, monkeypatch, size: int) -> None:
    answered: list[str] = []
    monkeypatch.setattr(bridge.home, "answer_text", answered.append)
    t0 = time.perf_counter()
    bridge._on_text({"data": "bring me the tomato " * (size // 20) + "x" * (size % 20)})
    assert time.perf_counter() - t0 < 0.5
    time.sleep(0.05)
    assert answered == [] and bridge._text_pending == 0
    (err,) = _errors(bridge.test_log)
    assert f"at most {MAX_TEXT_CHARS} characters" in err["detail"] and "/speech/text" in err["detail"]
    assert len(json.dumps(err)) < 1000  # the text itself is not echoed back


def test_a_text_at_the_limit_is_answered(bridge, monkeypatch) -> None:
    answered: list[str] = []
    monkeypatch.setattr(bridge.home, "answer_text", answered.append)
    text = ("bring me the tomato " * 30)[:MAX_TEXT_CHARS]
    bridge._on_text({"data": text})
    deadline = time.monotonic() + 5
    while not answered and time.monotonic() < deadline:
        time.sleep(0.01)
    assert answered == [text.strip()] and _errors(bridge.test_log) == []


@pytest.mark.parametrize("data", [
    "walk(human, " + "k" * MAX_TEXT_CHARS + ")",
    "\n".join(["walk(human, counter)"] * (MAX_ACTIONS_PER_REQUEST + 1)),
    "x" * 1_000_000,
])
def test_oversized_actions_are_refused_before_any_work(bridge, monkeypatch, data: str) -> None:
    observed: list[list[str]] = []
    monkeypatch.setattr(bridge.home, "observe", lambda lines: observed.append(lines) or [])
    t0 = time.perf_counter()
    bridge._on_actions({"data": data})
    assert time.perf_counter() - t0 < 0.5
    assert observed == []
    (err,) = _errors(bridge.test_log)
    assert str(MAX_ACTIONS_PER_REQUEST) in err["detail"] and str(MAX_TEXT_CHARS) in err["detail"]
    assert len(json.dumps(err)) < 1000


def test_the_bridge_answers_after_a_megabyte_over_the_wire(bridge) -> None:
    rb, log = bridge.test_rb, bridge.test_log
    with ws_client.connect(rb.url, max_size=None) as robot:
        robot.send(json.dumps({"op": "publish", "topic": "/speech/text", "msg": {"data": "a" * 1_000_000}}))
        robot.send(json.dumps({"op": "publish", "topic": "/siftom/actions", "msg": {"data": "[Walk] <kitchen> (1)"}}))
        t0 = time.monotonic()
        assert rb.wait_for(lambda: any(o.get("event") == "actions" for o in log), 10), log[-3:]
        assert time.monotonic() - t0 < 5
    assert len(_errors(log)) == 1 and "at most" in _errors(log)[0]["detail"]
