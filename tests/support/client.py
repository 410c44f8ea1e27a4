"""A test client that talks to an app as a browser on this machine does."""

from __future__ import annotations

from typing import Any
from urllib.parse import urljoin

from fastapi.testclient import TestClient

LOCAL = "http://localhost"


class LocalClient(TestClient):
    """A TestClient whose WebSockets go to its ``base_url`` too (TestClient's own always say
    ``Host: testserver``)."""

    def websocket_connect(self, url: str, subprotocols: Any = None, **kwargs: Any) -> Any:
        base = str(self.base_url).replace("http://", "ws://", 1).replace("https://", "wss://", 1)
        return super().websocket_connect(urljoin(base, url), subprotocols, **kwargs)


def local_client(app: Any, **kw: Any) -> TestClient:
    """``TestClient(app)`` sending ``Host: localhost`` (its default name, ``testserver``, is not one
    a siftom server answers to: the Host allow-list guards against DNS rebinding)."""
    return LocalClient(app, base_url=kw.pop("base_url", LOCAL), **kw)


def as_localhost(app: Any) -> Any:
    """``app`` as reached at ``localhost`` whatever Host a test harness sends (schemathesis' ASGI
    client says ``testserver``)."""

    async def local(scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            headers = [(k, v) for k, v in scope.get("headers", []) if k.lower() != b"host"]
            scope = {**scope, "headers": [*headers, (b"host", b"localhost")]}
        await app(scope, receive, send)

    return local
