"""A local server that speaks the rosbridge v2 protocol (the part a topic bridge uses): clients
``advertise``/``unadvertise`` and ``subscribe``/``unsubscribe`` topics, and a ``publish`` op is
forwarded to every subscriber of its topic as ``{"op": "publish", "topic", "msg"}``. Every op
received is logged (``ops``), so a test can compare the exchange with a recorded one.

Runs an asyncio ``websockets`` server in a thread: ``with FakeRosbridge() as rb: rb.url``.
"""

from __future__ import annotations

import asyncio
import json
import threading
import time
from typing import Any


class FakeRosbridge:
    def __init__(self) -> None:
        self.ops: list[dict[str, Any]] = []  # every op received, in order
        self.subscribers: dict[str, set[Any]] = {}
        self.advertised: dict[str, str] = {}  # topic -> type
        self.clients: set[Any] = set()
        self.advertised_by: dict[Any, set[str]] = {}  # a connection's advertisements (gone with it)
        self.unadvertised: list[dict[str, Any]] = []  # publishes on a topic their connection has not advertised
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Future | None = None
        self._ready = threading.Event()
        self.port = 0

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    async def _handle(self, ws: Any) -> None:
        self.clients.add(ws)
        try:
            async for raw in ws:
                op = json.loads(raw)
                self.ops.append(op)
                kind, topic = op.get("op"), op.get("topic")
                if kind == "subscribe":
                    self.subscribers.setdefault(topic, set()).add(ws)
                elif kind == "unsubscribe":
                    self.subscribers.get(topic, set()).discard(ws)
                elif kind == "advertise":
                    self.advertised[topic] = op.get("type", "")
                    self.advertised_by.setdefault(ws, set()).add(topic)
                elif kind == "publish":
                    if topic not in self.advertised_by.get(ws, ()):
                        # rosbridge infers the type from other clients, or refuses it when it cannot
                        self.unadvertised.append(op)
                    out = json.dumps({"op": "publish", "topic": topic, "msg": op.get("msg", {})})
                    for sub in list(self.subscribers.get(topic, ())):
                        try:
                            await sub.send(out)
                        except Exception:
                            self.subscribers[topic].discard(sub)
        except Exception:  # dropped (see drop)
            pass
        finally:
            self.clients.discard(ws)
            self.advertised_by.pop(ws, None)
            for subs in self.subscribers.values():
                subs.discard(ws)

    def drop(self) -> None:
        """Close every client connection (as a rosbridge restart or a network cut does)."""
        assert self._loop is not None
        for ws in list(self.clients):
            asyncio.run_coroutine_threadsafe(ws.close(), self._loop).result(5)

    async def _main(self) -> None:
        import websockets

        self._stop = asyncio.get_running_loop().create_future()
        async with websockets.serve(self._handle, "127.0.0.1", 0, max_size=2**24, close_timeout=0.5) as server:
            self.port = server.sockets[0].getsockname()[1]
            self._ready.set()
            await self._stop

    def __enter__(self) -> FakeRosbridge:
        def run() -> None:
            self._loop = asyncio.new_event_loop()
            self._loop.run_until_complete(self._main())

        self._thread = threading.Thread(target=run, daemon=True, name="fake-rosbridge")
        self._thread.start()
        assert self._ready.wait(10), "the fake rosbridge did not start"
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set_result, None)
        self._thread.join(5)

    def wait_for(self, predicate: Any, timeout: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if predicate():
                return True
            time.sleep(0.02)
        return False
