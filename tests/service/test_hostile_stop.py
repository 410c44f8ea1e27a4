"""SIGTERM with a request in flight: once the stop grace runs out the request is answered with a
503 problem document saying the server is stopping and how to retry (uvicorn's own answer was a
plain-text 500)."""

from __future__ import annotations

import asyncio
import json
import signal
import socket
import subprocess
import sys
import time
from typing import Any

from siftom.service.local_server import free_port
from siftom.service.problems import _KeepConnectionMiddleware


def test_a_request_cancelled_by_the_stop_is_a_503_problem() -> None:
    async def slow(scope: Any, receive: Any, send: Any) -> None:
        raise asyncio.CancelledError("Task cancelled, timeout graceful shutdown exceeded")

    sent: list[dict[str, Any]] = []

    async def send(msg: dict[str, Any]) -> None:
        sent.append(msg)

    asyncio.run(_KeepConnectionMiddleware(slow)({"type": "http", "method": "POST", "path": "/v1/infer"},
                                                 None, send))  # type: ignore[arg-type]
    start, body = sent
    headers = dict(start["headers"])
    assert start["status"] == 503 and headers[b"content-type"] == b"application/problem+json"
    assert headers[b"retry-after"] == b"5" and headers[b"connection"] == b"close"
    problem = json.loads(body["body"])
    assert problem["type"] == "urn:siftom:problem:stopping" and "Idempotency-Key" in problem["detail"]


def test_sigterm_with_an_upload_in_flight_answers_a_problem_after_the_grace(tmp_path) -> None:
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "siftom.cli", "serve", "--port", str(port),
                             "--data-dir", str(tmp_path / "data")],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=1)
                break
            except OSError:
                assert time.monotonic() < deadline and proc.poll() is None, "the server did not start"
                time.sleep(0.1)
        with sock:
            sock.settimeout(30)
            sock.sendall(b"POST /v1/infer HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                         b"Content-Length: 1000\r\n\r\n{\"scenario\": ")  # the rest of the body never comes
            time.sleep(0.5)
            proc.send_signal(signal.SIGTERM)
            data = b""
            while chunk := sock.recv(65536):
                data += chunk
        head, _, body = data.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 503"), data[:300]
        assert b"content-type: application/problem+json" in head.lower()
        assert json.loads(body)["type"] == "urn:siftom:problem:stopping"
        proc.wait(30)
        assert proc.returncode == -signal.SIGTERM
        assert "Exception in ASGI application" not in proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
