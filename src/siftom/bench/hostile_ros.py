"""The ROS bridge under hostile messages, for ``siftom bench hostile``: a local relay that speaks
the part of the rosbridge v2 protocol a topic bridge uses (subscribe, advertise, publish
forwarded to subscribers), ``siftom ros`` on it as its own process (the bench does not import the
service: it reads the bridge's JSON lines), and a robot that publishes oversized text and action
lines, then one instruction that must still be answered."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from siftom.errors import SiftomError

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


def _bridge_process(relay_url: str, scenario: str, log: Any) -> subprocess.Popen[str]:
    """``siftom ros`` on ``relay_url`` as its own process (the bench does not import the service):
    its JSON lines on stdout, its notes on ``log``."""
    src = str(Path(__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-m", "siftom.cli", "ros", "--rosbridge", relay_url,
                             "--scenario", scenario, "--text-topic", "/speech/text", "--audio-topic", ""],
                            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log, text=True,
                            encoding="utf-8", errors="replace")


def _read_lines(proc: subprocess.Popen[str], lines: list[tuple[float, dict[str, Any]]]) -> None:
    """Each JSON line the bridge prints, with the time it came."""
    assert proc.stdout is not None
    for raw in proc.stdout:
        with contextlib.suppress(ValueError):
            obj = json.loads(raw)
            if isinstance(obj, dict):
                lines.append((time.monotonic(), obj))


def _wait_subscribed(relay: Relay, proc: subprocess.Popen[str], log: Any, timeout: float) -> None:
    """Until the bridge subscribes to its text and action topics on the relay."""
    deadline = time.monotonic() + timeout
    while not all(relay.subscribers.get(t) for t in ("/speech/text", "/siftom/actions")):
        if proc.poll() is not None or time.monotonic() > deadline:
            log.flush()
            log.seek(0)
            tail = log.read()[-400:].strip()
            raise SiftomError(f"siftom ros did not subscribe on {relay.url} within {timeout:g} s"
                              + (f": {tail}" if tail else ""))
        time.sleep(0.05)


def _stop(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


@contextlib.contextmanager
def bridged(scenario: str = "kitchen-cereal-v0", startup_timeout: float = 90.0) -> Iterator[Any]:
    """A relay, ``siftom ros`` on it as its own process (text topic ``/speech/text``) and a robot
    connection; yields ``send(topic, data) -> RosOutcome``."""
    from websockets.sync.client import connect

    lines: list[tuple[float, dict[str, Any]]] = []
    with Relay() as relay, tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace") as log:
        proc = _bridge_process(relay.url, scenario, log)
        decisions: list[tuple[float, str]] = []
        try:
            threading.Thread(target=_read_lines, args=(proc, lines), daemon=True).start()
            _wait_subscribed(relay, proc, log, startup_timeout)
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
            _stop(proc)
