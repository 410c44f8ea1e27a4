"""An app served on a loopback port from a background thread, for the load tools and tests:
:func:`serve_in_thread` yields its base URL and stops it on exit; :func:`free_port` finds a port."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

from siftom.errors import SiftomError


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free right now on ``host``."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def serve_in_thread(app: Any, host: str = "127.0.0.1", port: int | None = None,
                    startup_timeout: float = 30.0, trusted_proxies: tuple[str, ...] = ()) -> Iterator[str]:
    """Run ``app`` with uvicorn in a daemon thread; yield its base URL; stop it on exit. The app's
    lifespan does not run (no start-up work, e.g. no model warm-up). ``X-Forwarded-*`` headers are
    read only from ``trusted_proxies`` (as ``siftom serve --trusted-proxy``)."""
    import uvicorn

    from siftom.service.hosts import proxy_options

    port = port or free_port(host)
    proxy_headers, forwarded = proxy_options(trusted_proxies)
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", access_log=False, lifespan="off",
                            proxy_headers=proxy_headers, forwarded_allow_ips=forwarded)
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, name="siftom-serve", daemon=True)
    thread.start()
    deadline = time.monotonic() + startup_timeout
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            server.should_exit = True
            raise SiftomError(f"the server did not start on {host}:{port} within {startup_timeout:g} s")
        time.sleep(0.02)
    try:
        yield f"http://{host}:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=10)
