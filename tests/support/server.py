"""A real ``siftom serve`` process for fault tests: start it, wait until it answers, kill it hard."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[2]


def server_env() -> dict[str, str]:
    """The environment with this checkout's sources first on the path."""
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}


def start_server(port: int, data_dir: Path, wait_s: float = 90.0) -> subprocess.Popen:
    """``siftom serve --port PORT --data-dir DATA_DIR`` in its own process group, once /healthz answers."""
    proc = subprocess.Popen([sys.executable, "-m", "siftom.cli", "serve", "--port", str(port), "--data-dir",
                             str(data_dir)], env=server_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise AssertionError(f"siftom serve exited: {proc.stderr.read().decode()[-2000:]}")  # type: ignore[union-attr]
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                return proc
        except httpx.HTTPError:
            time.sleep(0.2)
    proc.kill()
    raise AssertionError(f"siftom serve did not answer /healthz within {wait_s:.0f} s")


def kill_server(proc: subprocess.Popen) -> None:
    """SIGKILL the server's whole process group (no clean shutdown) and reap it."""
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10)
