"""Helpers for the streaming tests: an instruction recorded with ``siftom say``, PCM chunks, and a
WebSocket client that collects the server's events while audio is sent."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
RATE = 16_000


def say(text: str, out: Path) -> np.ndarray:
    """``siftom say TEXT -o OUT`` as a user runs it; the samples (skips the test without a voice)."""
    import soundfile as sf

    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-m", "siftom.cli", "say", text, "-o", str(out)], env=env,
                         capture_output=True, text=True, timeout=120)
    if res.returncode != 0:
        pytest.skip(f"siftom say failed (no TTS voice?): {res.stderr.strip()[-300:]}")
    x, rate = sf.read(out, dtype="float32")
    assert rate == RATE
    return x


def noise_clip(name: str, seconds: float) -> np.ndarray:
    """``seconds`` of a recorded noise clip (looped when shorter)."""
    import soundfile as sf

    from siftom.speech.noise import RECORDED_NOISE_DIR

    x, rate = sf.read(RECORDED_NOISE_DIR / name, dtype="float32")
    assert rate == RATE and x.ndim == 1
    n = int(seconds * RATE)
    return np.resize(x, n).astype(np.float32)


def silence(seconds: float) -> np.ndarray:
    return np.zeros(int(seconds * RATE), dtype=np.float32)


def pcm16(x: np.ndarray) -> bytes:
    return (np.clip(x, -1.0, 1.0) * 32767).astype("<i2").tobytes()


class Collector:
    """Reads a websockets (sync) connection in a thread: ``events`` (JSON), then ``close`` (code, reason)."""

    def __init__(self, ws: Any) -> None:
        self.ws, self.events, self.close = ws, [], None
        self.times: list[float] = []
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from websockets.exceptions import ConnectionClosed

        try:
            while True:
                msg = self.ws.recv()
                self.times.append(time.perf_counter())
                self.events.append(json.loads(msg))
        except ConnectionClosed as exc:
            rcvd = exc.rcvd
            self.close = (rcvd.code, rcvd.reason) if rcvd is not None else (None, "")

    def wait(self, timeout: float = 30.0) -> tuple[int | None, str]:
        self._thread.join(timeout)
        assert not self._thread.is_alive(), "the server did not close the stream"
        assert self.close is not None
        return self.close

    def ready(self, timeout: float = 30.0) -> dict[str, Any]:
        """Wait for the server's ``ready`` event (send audio after it: the recogniser is built first)."""
        deadline = time.monotonic() + timeout
        while not self.events and self.close is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert self.events and self.events[0]["event"] == "ready", (self.events, self.close)
        return self.events[0]

    def of(self, kind: str) -> list[dict[str, Any]]:
        return [e for e in self.events if e.get("event") == kind]


def stream(ws: Any, pcm: bytes, chunk_ms: int = 20, realtime: bool = True) -> float:
    """Send ``pcm`` in ``chunk_ms`` chunks, in real time or as fast as possible; returns the
    wall time (perf_counter) when the stream started."""
    step = RATE * 2 * chunk_ms // 1000
    t0 = time.perf_counter()
    for k in range(0, len(pcm), step):
        ws.send(pcm[k:k + step])
        if realtime:
            time.sleep(max(0.0, t0 + (k + step) / (2 * RATE) - time.perf_counter()))
    return t0
