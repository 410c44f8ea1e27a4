"""Slow clients are cut off: headers not complete within the header deadline (nothing sent at
all, or a line now and then) get a 408 and the connection closed; a body still arriving at the
body deadline is disconnected. A real uvicorn server with deadlines shortened, raw sockets."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import uvicorn

from siftom.service.app import create_app
from siftom.service.slow_clients import deadline_protocol

HEADER_S, BODY_S = 0.5, 1.0


@pytest.fixture(scope="module")
def port(tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    app = create_app(tmp_path_factory.mktemp("slow"))
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    config = uvicorn.Config(app, log_level="warning", http=deadline_protocol(HEADER_S, BODY_S), lifespan="off")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 10
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.02)
    assert server.started
    yield sock.getsockname()[1]
    server.should_exit = True
    thread.join(10)
    app.state.runtime.close()


def _closed_within(conn: socket.socket, seconds: float) -> tuple[float, bytes]:
    """Read until the server closes the connection; (seconds it took, what it sent)."""
    conn.settimeout(seconds)
    t0, got = time.monotonic(), b""
    try:
        while chunk := conn.recv(4096):
            got += chunk
    except TimeoutError:
        pytest.fail(f"the connection is still open after {seconds} s")
    except ConnectionResetError:
        pass
    return time.monotonic() - t0, got


def _response(conn: socket.socket) -> bytes:
    """One whole response (headers and a Content-Length body)."""
    got = b""
    while b"\r\n\r\n" not in got:
        chunk = conn.recv(65536)
        assert chunk, got
        got += chunk
    head, _, body = got.partition(b"\r\n\r\n")
    length = next(int(ln.split(b":")[1]) for ln in head.lower().split(b"\r\n") if ln.startswith(b"content-length:"))
    while len(body) < length:
        chunk = conn.recv(65536)
        assert chunk, got
        body += chunk
    return head + b"\r\n\r\n" + body


def test_a_client_that_sends_nothing_is_closed(port: int) -> None:
    with socket.create_connection(("127.0.0.1", port)) as c:
        took, got = _closed_within(c, HEADER_S + 3)
    assert got.startswith(b"HTTP/1.1 408"), got
    assert HEADER_S * 0.8 <= took < HEADER_S + 2


def test_slow_headers_are_closed_at_the_deadline(port: int) -> None:
    with socket.create_connection(("127.0.0.1", port)) as c:
        c.sendall(b"GET /healthz HTTP/1.1\r\nHost: localhost\r\n")
        t0 = time.monotonic()
        try:
            for _ in range(20):  # a header line now and then never completes the request
                time.sleep(HEADER_S / 4)
                c.sendall(b"X-Slow: 1\r\n")
        except (BrokenPipeError, ConnectionResetError):
            pass
        took, got = _closed_within(c, HEADER_S + 3)
        assert time.monotonic() - t0 < HEADER_S + 2
    assert got.startswith(b"HTTP/1.1 408"), got


def test_a_slow_body_is_disconnected(port: int) -> None:
    with socket.create_connection(("127.0.0.1", port)) as c:
        c.sendall(b"POST /v1/sessions HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\n"
                  b"Content-Length: 1000\r\n\r\n{\"world\":")
        t0 = time.monotonic()
        try:
            for _ in range(40):
                time.sleep(BODY_S / 8)
                c.sendall(b" ")
        except (BrokenPipeError, ConnectionResetError):
            pass
        _closed_within(c, BODY_S + 3)
        assert time.monotonic() - t0 < BODY_S + 2


def test_prompt_clients_are_served_and_kept_alive(port: int) -> None:
    with socket.create_connection(("127.0.0.1", port)) as c:
        c.settimeout(5)
        for _ in range(2):  # two requests on one connection, the second after the header deadline
            c.sendall(b"GET /healthz HTTP/1.1\r\nHost: localhost\r\n\r\n")
            got = _response(c)
            assert got.startswith(b"HTTP/1.1 200"), got[:200]
            time.sleep(HEADER_S * 1.5)


def test_the_serve_command_has_the_deadlines(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from siftom.cli.service import serve_cmd

    out = CliRunner().invoke(serve_cmd, ["--help"]).output
    assert "--header-timeout" in out and "--body-timeout" in out
