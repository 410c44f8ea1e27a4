"""``siftom serve`` on a port already in use: a one-line error naming the port and the fix
(``--port``), exit status 2, before anything (a model warm-up) starts; never a crash."""

from __future__ import annotations

import socket
import subprocess
import sys
import time


def test_a_port_in_use_is_a_one_line_error(tmp_path) -> None:
    held = socket.socket()
    held.bind(("127.0.0.1", 0))
    held.listen()
    port = held.getsockname()[1]
    try:
        for _ in range(3):
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-m", "siftom.cli", "serve", "--port", str(port),
                                "--data-dir", str(tmp_path / "data")],
                               capture_output=True, text=True, timeout=60)
            took = time.perf_counter() - t0
            lines = [ln for ln in (p.stdout + p.stderr).splitlines() if ln.strip()]
            assert p.returncode in (1, 2), (p.returncode, p.stderr[-2000:])
            assert len(lines) == 1, lines
            assert str(port) in lines[0] and "--port" in lines[0] and "in use" in lines[0], lines[0]
            assert took < 10, took
    finally:
        held.close()
