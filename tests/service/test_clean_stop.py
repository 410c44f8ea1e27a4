"""``siftom serve`` stopped by SIGTERM or SIGINT (while serving, with a stream open, or while it
still warms up) ends within 10 s and releases its data folder: the lock file and its owner
record are gone, so the next server starts without a note about a stale lock."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from siftom.bench.runlock import LOCK

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _serve(data: Path, port: int) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-m", "siftom.cli", "serve", "--port", str(port), "--data-dir", str(data)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _stopped(proc: subprocess.Popen[str], signum: int) -> str:
    t0 = time.monotonic()
    proc.send_signal(signum)
    try:
        _, err = proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"siftom serve was still running 10 s after {signal.Signals(signum).name}: {err[-2000:]}")
    assert time.monotonic() - t0 < 10
    assert proc.returncode == -signum, (proc.returncode, err[-2000:])  # ended by the signal, after cleaning up
    assert f"stopped by {signal.Signals(signum).name}" in err and "Traceback" not in err, err[-2000:]
    return err


def test_sigterm_while_serving_with_a_stream_open_releases_the_folder(tmp_path: Path) -> None:
    ws_client = pytest.importorskip("websockets.sync.client")
    data, port = tmp_path / "data", _port()
    proc = _serve(data, port)
    try:
        url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 120
        while True:
            try:
                if httpx.get(f"{url}/healthz", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            assert proc.poll() is None and time.monotonic() < deadline, "the server did not start"
            time.sleep(0.2)
        assert (data / LOCK).exists()
        sid = httpx.post(f"{url}/v1/sessions/from-scenario", json={"scenario": "kitchen-cereal-v0"},
                         timeout=30).raise_for_status().json()["id"]
        with ws_client.connect(f"ws://127.0.0.1:{port}/v1/sessions/{sid}/listen", open_timeout=30) as ws:
            ws.recv(timeout=60)  # ready
            _stopped(proc, signal.SIGTERM)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not (data / LOCK).exists()
    assert (data / "sessions.sqlite3").exists()  # the sessions stay for the next server


def test_sigint_during_warm_up_releases_the_folder(tmp_path: Path) -> None:
    data = tmp_path / "data"
    proc = _serve(data, _port())
    try:
        deadline = time.monotonic() + 60
        while not (data / LOCK).exists():  # the folder is claimed first, then the app is built
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.005)
        _stopped(proc, signal.SIGINT)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not (data / LOCK).exists()
