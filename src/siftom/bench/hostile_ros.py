"""The ROS bridge under hostile messages, for ``siftom bench hostile``: a local relay that speaks
the part of the rosbridge v2 protocol a topic bridge uses (subscribe, advertise, publish
forwarded to subscribers), a :class:`~siftom.service.ros.RosBridge` on it, and a robot that
publishes oversized text and action lines, then one instruction that must still be answered."""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

SPOKEN = "can you get me the tomato"


class Relay:
    """A rosbridge-protocol relay on a loopback port, in a thread: ``with Relay() as r: r.url``."""

    def __init__(self) -> None:
        self.subscribers: dict[str, set[Any]] = {}
        self.port = 0
        self._ready = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Future[None] | None = None

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    async def _handle(self, ws: Any) -> None:
        try:
            async for raw in ws:
                op = json.loads(raw)
                kind, topic = op.get("op"), op.get("topic")
                if kind == "subscribe":
                    self.subscribers.setdefault(topic, set()).add(ws)
                elif kind == "publish":
                    out = json.dumps({"op": "publish", "topic": topic, "msg": op.get("msg", {})})
                    for sub in list(self.subscribers.get(topic, ())):
                        with contextlib.suppress(Exception):
                            await sub.send(out)
        except Exception:  # a connection dropped
            pass
        finally:
            for subs in self.subscribers.values():
                subs.discard(ws)

    async def _main(self) -> None:
        import websockets

        self._stop = asyncio.get_running_loop().create_future()
        async with websockets.serve(self._handle, "127.0.0.1", 0, max_size=2**24) as server:
            self.port = server.sockets[0].getsockname()[1]
            self._ready.set()
            await self._stop

    def __enter__(self) -> Relay:
        def run() -> None:
            self._loop = asyncio.new_event_loop()
            self._loop.run_until_complete(self._main())

        self._thread = threading.Thread(target=run, daemon=True, name="siftom-bench-rosbridge")
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("the local rosbridge relay did not start")
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set_result, None)
        self._thread.join(5)


@dataclass(frozen=True)
class RosOutcome:
    """What one message to the bridge got: the error line naming a limit (``refused``) or a decision
    (``decided``), and how long after publishing it came; ``said``: the line or decision, shortened."""

    refused: bool
    decided: bool
    seconds: float
    said: str


@contextlib.contextmanager
def bridged(scenario: str = "kitchen-cereal-v0") -> Iterator[Any]:
    """A relay, a bridge on it (text topic ``/speech/text``) and a robot connection; yields
    ``send(topic, data) -> RosOutcome``."""
    from websockets.sync.client import connect

    from siftom.listener import HomeListener, load_home
    from siftom.service.ros import RosBridge, RosTopics

    lines: list[tuple[float, dict[str, Any]]] = []
    with Relay() as relay:
        bridge = RosBridge(HomeListener(load_home(scenario=scenario)), relay.url, RosTopics(text="/speech/text"),
                           out=lambda e: lines.append((time.monotonic(), e.to_json())))
        decisions: list[tuple[float, str]] = []
        try:
            with connect(relay.url, max_size=2**24) as robot:
                robot.send(json.dumps({"op": "subscribe", "topic": "/siftom/decision"}))

                def listen() -> None:
                    with contextlib.suppress(Exception):
                        for raw in robot:
                            msg = json.loads(raw).get("msg", {})
                            decisions.append((time.monotonic(), str(msg.get("data", ""))))

                threading.Thread(target=listen, daemon=True).start()
                time.sleep(0.2)  # the subscription is in place

                def send(topic: str, data: str, timeout: float = 30.0) -> RosOutcome:
                    n_lines, n_dec = len(lines), len(decisions)
                    t0 = time.monotonic()
                    robot.send(json.dumps({"op": "publish", "topic": topic, "msg": {"data": data}}))
                    while time.monotonic() - t0 < timeout:
                        errs = [(t, o) for t, o in lines[n_lines:] if o.get("event") == "error"]
                        if errs:
                            return RosOutcome(True, False, round(errs[0][0] - t0, 3), str(errs[0][1].get("detail")))
                        if len(decisions) > n_dec:
                            t, body = decisions[n_dec]
                            return RosOutcome(False, True, round(t - t0, 3), body[:160])
                        time.sleep(0.005)
                    return RosOutcome(False, False, round(time.monotonic() - t0, 3), "nothing within "
                                      f"{timeout:g} s")

                yield send
        finally:
            bridge.stop()
            bridge._terminate()
