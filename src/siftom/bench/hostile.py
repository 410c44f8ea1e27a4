"""``siftom bench hostile``: requests built to exhaust the service (huge worlds, huge names), each
sent once to a server while ``/healthz`` is polled; each must be refused at once with a 4xx naming
its limit, and the server must stay responsive meanwhile.

Beside them, the doors that are not plain requests:

* **stream slots**: every slot (``max_streams``, 8) taken by a stream trickling two bytes every
  two seconds; each must be closed (4408) once its audio lags real time by the allowance (10 s),
  and a robot's stream must then get a slot; an action line of 5,000 characters on a stream is
  an ``error`` event (422), a 1 MB text message a 1009;
* **headers**: wrong tokens each with a fresh ``X-Forwarded-For`` must be throttled (429) on the
  connection's address, and so must the right token under a fresh header meanwhile (run last:
  the bench's own address is throttled for a minute after);
* **ROS**: a bridge on a local rosbridge relay given a 300 KB and a 1 MB ``std_msgs/String`` text
  and a 100,000-character action line must refuse each with an error line naming the limit
  within a second, and answer the instruction that follows within five seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
import time
from dataclasses import dataclass
from typing import Any

from siftom.bench.machine import Machine
from siftom.bench.robots import local_server

_PNG = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg=="


def _hostile_world(n_places: int = 3, cls: str = "tomato") -> dict[str, Any]:
    """A world JSON with ``n_places`` places and one object of class ``cls``."""
    places = [{"name": f"p{i}", "kind": "surface", "room": f"r{i % 7}", "pos": [i % 50, i // 50]}
              for i in range(n_places)]
    return {"places": places, "items": [{"name": "o0", "class": cls, "at": "p0"}], "target": "p0",
            "goals": [{"name": "g", "counts": {cls: 1}}]}


def _hostile_requests() -> list[tuple[str, str, dict[str, Any]]]:
    """(name, path, JSON body) of each hostile request the service must refuse at once."""
    return [
        ("3,000-place world", "/v1/sessions", {"world": _hostile_world(3000)}),
        ("1,000-place world", "/v1/sessions", {"world": _hostile_world(1000)}),
        ("100,000-letter class names", "/v1/sessions", {"world": _hostile_world(4, "a" * 100_000)}),
        ("6,000-node scene graph", "/v1/sessions",
         {"world": {"nodes": [{"id": k, "class_name": "chair"} for k in range(6000)], "edges": []}}),
        ("perceive, 1,000 places", "/v1/perceive", {"frames": [_PNG], "world": _hostile_world(1000)}),
        ("perceive, 100,000-letter class", "/v1/perceive", {"frames": [_PNG], "world": _hostile_world(4, "b" * 100_000)}),
    ]


NOT_RUN = -1  # the status of a case this machine cannot run (a missing extra, no token); ``detail`` says why


@dataclass(frozen=True)
class HostileRow:
    """One hostile input: what was sent, the answer's status (an HTTP status, a WebSocket close
    code, 422 for a refusal line or event, 200 for a decision), how long it took, what it said,
    and the slowest of the ``/healthz`` polls (and their number) meanwhile. ``expect``: the status
    it must get (0: any 4xx), within ``within_s`` seconds."""

    input: str
    path: str
    status: int
    seconds: float
    detail: str
    healthz_max_ms: float | None
    healthz_n: int
    expect: int = 0
    within_s: float = 1.0

    def to_json(self) -> dict[str, Any]:
        """The row's entry in ``results/service/hostile.json``."""
        return {"input": self.input, "path": self.path, "status": self.status, "seconds": self.seconds,
                "detail": self.detail, "healthz_max_ms": self.healthz_max_ms, "healthz_n": self.healthz_n,
                "expect": self.expect, "within_s": self.within_s}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> HostileRow:
        """Read :meth:`to_json`'s form."""
        return cls(data["input"], data.get("path", ""), data["status"], data["seconds"], data["detail"],
                   data.get("healthz_max_ms"), data.get("healthz_n", 0), data.get("expect", 0),
                   data.get("within_s", 1.0))

    @property
    def ran(self) -> bool:
        return self.status != NOT_RUN

    def meets(self) -> bool:
        """The expected status (a 4xx by default) within ``within_s``, ``/healthz`` within 100 ms meanwhile."""
        status_ok = 400 <= self.status < 500 if self.expect == 0 else self.status == self.expect
        return status_ok and self.seconds < self.within_s and (self.healthz_max_ms or 0) < 100


@dataclass(frozen=True)
class HostileResult:
    """Every hostile request's row, where they ran, and whether all of them met the floors."""

    machine: Machine
    rows: tuple[HostileRow, ...]
    meets: bool

    def to_json(self) -> dict[str, Any]:
        """The ``results/service/hostile.json`` form."""
        return {"machine": self.machine.to_json(), "rows": [r.to_json() for r in self.rows], "meets": self.meets}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> HostileResult:
        """Read :meth:`to_json`'s form."""
        return cls(Machine.from_json(data.get("machine")), tuple(HostileRow.from_json(r) for r in data["rows"]),
                   bool(data.get("meets", False)))


async def _hostile(url: str, headers: dict[str, str]) -> list[HostileRow]:
    import httpx

    rows = []
    async with httpx.AsyncClient(base_url=url, headers=headers, timeout=120) as client:
        await client.post("/v1/sessions", json={"world": _hostile_world()})  # warm: the first request loads models
        for name, path, body in _hostile_requests():
            health: list[float] = []
            done = asyncio.Event()

            async def poll(health: list[float] = health, done: asyncio.Event = done) -> None:
                while not done.is_set():
                    t0 = time.perf_counter()
                    await client.get("/healthz")
                    health.append((time.perf_counter() - t0) * 1000)
                    await asyncio.sleep(0.01)

            poller = asyncio.create_task(poll())
            await asyncio.sleep(0.05)
            t0 = time.perf_counter()
            r = await client.post(path, json=body)
            took = time.perf_counter() - t0
            done.set()
            await poller
            detail = r.json().get("detail", "") if r.headers.get("content-type", "").endswith("json") else r.text
            rows.append(HostileRow(name, path, r.status_code, round(took, 3), str(detail)[:160],
                                   round(max(health), 1) if health else None, len(health)))
    return rows


class _Health:
    """``/healthz`` polled every 10 ms while a case runs: the slowest answer and the count."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.ms: list[float] = []
        self._done = asyncio.Event()

    async def _poll(self) -> None:
        while not self._done.is_set():
            t0 = time.perf_counter()
            with contextlib.suppress(Exception):
                await self.client.get("/healthz")
            self.ms.append((time.perf_counter() - t0) * 1000)
            await asyncio.sleep(0.01)

    async def __aenter__(self) -> _Health:
        self._task = asyncio.create_task(self._poll())
        await asyncio.sleep(0.05)
        return self

    async def __aexit__(self, *exc: Any) -> None:
        self._done.set()
        await self._task

    def row(self, name: str, path: str, status: int, seconds: float, detail: str, expect: int = 0,
            within_s: float = 1.0) -> HostileRow:
        return HostileRow(name, path, status, round(seconds, 3), detail[:160],
                          round(max(self.ms), 1) if self.ms else None, len(self.ms), expect, within_s)


LISTEN = "WS /v1/sessions/{id}/listen"
TRICKLE_STREAMS = 8  # siftom serve's max_streams
TRICKLE_EVERY_S = 2.0


async def _close_of(ws: Any, timeout: float) -> tuple[int, str, list[dict[str, Any]]]:
    """Read ``ws`` until it closes: (close code, reason, JSON events); code 0 when it did not close."""
    from websockets.exceptions import ConnectionClosed

    events: list[dict[str, Any]] = []
    try:
        async with asyncio.timeout(timeout):
            while True:
                events.append(json.loads(await ws.recv()))
    except ConnectionClosed as exc:
        rcvd = exc.rcvd
        return (rcvd.code, rcvd.reason, events) if rcvd is not None else (0, "closed without a code", events)
    except TimeoutError:
        return 0, f"still open after {timeout:g} s", events


async def _stream_rows(client: Any, url: str, headers: dict[str, str]) -> list[HostileRow]:
    """The stream-slot, action-line and text-size cases over ``WS /v1/sessions/{id}/listen``."""
    try:
        import websockets
    except ModuleNotFoundError:
        return [HostileRow("stream cases", LISTEN, NOT_RUN, 0.0, "not run: needs websockets (pip install "
                           "'siftom[stream]')", None, 0)]

    async def session() -> str:
        r = await client.post("/v1/sessions", json={"world": _hostile_world()})
        return str(r.json()["id"])

    def ws_url(sid: str) -> str:
        return url.replace("http://", "ws://").replace("https://", "wss://") + f"/v1/sessions/{sid}/listen"

    async def opened(sid: str) -> Any:
        ws = await websockets.connect(ws_url(sid), additional_headers=headers, max_size=2**22)
        ready = json.loads(await ws.recv())
        if ready.get("event") != "ready":
            raise RuntimeError(f"no ready event: {ready}")
        return ws

    rows = []
    sids = [await session() for _ in range(TRICKLE_STREAMS + 3)]
    async with _Health(client) as health:
        trickles = [await opened(sid) for sid in sids[:TRICKLE_STREAMS]]
        t0 = time.perf_counter()

        async def trickle(ws: Any) -> tuple[int, str, float]:
            closing = asyncio.create_task(_close_of(ws, 40))
            while not closing.done():
                with contextlib.suppress(Exception):
                    await ws.send(b"\x00\x00")
                await asyncio.wait({closing}, timeout=TRICKLE_EVERY_S)
            code, reason, _ = closing.result()
            return code, reason, time.perf_counter() - t0

        closed = await asyncio.gather(*(trickle(ws) for ws in trickles))
        codes = sorted({c for c, _, _ in closed})
        last = max(t for _, _, t in closed)
        rows.append(health.row(f"{TRICKLE_STREAMS} streams trickling 2 bytes every {TRICKLE_EVERY_S:g} s", LISTEN,
                               codes[0] if len(codes) == 1 else 0, last, f"{closed[0][1]} (codes {codes})",
                               expect=4408, within_s=12.0))
    async with _Health(client) as health:
        t0 = time.perf_counter()
        try:
            ws = await opened(sids[TRICKLE_STREAMS])
            for _ in range(25):  # half a second of real-time silence, then the end
                await ws.send(b"\x00" * 640)
                await asyncio.sleep(0.02)
            await ws.send(json.dumps({"type": "end"}))
            code, reason, _ = await _close_of(ws, 10)
        except Exception as exc:  # refused: the slots are still held
            code, reason = getattr(getattr(exc, "rcvd", None), "code", 0) or 0, str(exc)
        rows.append(health.row("a robot's stream once they are closed", LISTEN, code, time.perf_counter() - t0,
                               reason or "end of stream", expect=1000, within_s=5.0))
    async with _Health(client) as health:
        ws = await opened(sids[TRICKLE_STREAMS + 1])
        t0 = time.perf_counter()
        await ws.send(json.dumps({"type": "actions", "actions": ["walk(human, " + "k" * 5_000 + ")"]}))
        event = json.loads(await asyncio.wait_for(ws.recv(), 10))
        took = time.perf_counter() - t0
        await ws.close()
        rows.append(health.row("a stream action line of 5,000 characters", LISTEN, int(event.get("status", 0)),
                               took, str(event.get("detail", event)), expect=422))
    async with _Health(client) as health:
        ws = await opened(sids[TRICKLE_STREAMS + 2])
        t0 = time.perf_counter()
        await ws.send(json.dumps({"type": "actions", "actions": ["walk(human, p0)"] * 52_000}))  # about 1 MB
        code, reason, _ = await _close_of(ws, 10)
        rows.append(health.row("a 1 MB stream text message", LISTEN, code, time.perf_counter() - t0, reason,
                               expect=1009))
    return rows


async def _header_rows(client: Any, token: str | None) -> list[HostileRow]:
    """Wrong tokens under a rotating ``X-Forwarded-For``, then the right one under a fresh header."""
    if token is None:
        return [HostileRow("wrong tokens, a fresh X-Forwarded-For each", "GET /v1/scenarios", NOT_RUN, 0.0,
                           "not run: the server has no token (give --token for a --url server)", None, 0)]
    rows = []
    async with _Health(client) as health:
        t0 = time.perf_counter()
        got = []
        for i in range(30):
            r = await client.get("/v1/scenarios", headers={"Authorization": f"Bearer wrong-guess-{i:010d}",
                                                           "X-Forwarded-For": f"198.51.100.{i + 1}"})
            got.append(r.status_code)
        rows.append(health.row("30 wrong tokens, a fresh X-Forwarded-For each", "GET /v1/scenarios", got[-1],
                               time.perf_counter() - t0, f"statuses {sorted(set(got))}; the 11th on is throttled",
                               expect=429))
    async with _Health(client) as health:
        t0 = time.perf_counter()
        r = await client.get("/v1/scenarios", headers={"Authorization": f"Bearer {token}",
                                                       "X-Forwarded-For": "203.0.113.77"})
        detail = r.json().get("detail", "") if "json" in r.headers.get("content-type", "") else r.text
        rows.append(health.row("the right token, a fresh X-Forwarded-For, while throttled", "GET /v1/scenarios",
                               r.status_code, time.perf_counter() - t0, str(detail), expect=429))
    return rows


def _ros_rows() -> list[HostileRow]:
    """Oversized text and action lines on the ROS bridge's topics, then an instruction."""
    try:
        import roslibpy  # noqa: F401
        import websockets  # noqa: F401
    except ModuleNotFoundError:
        return [HostileRow("ROS cases", "ROS /speech/text", NOT_RUN, 0.0,
                           "not run: needs the ros extra (pip install 'siftom[ros]')", None, 0)]
    from siftom.bench.hostile_ros import SPOKEN, bridged

    rows = []
    with bridged() as send:
        for name, topic, data in (("ROS text of 300 KB", "/speech/text", "bring me the cereal " * 15_000),
                                  ("ROS text of 1 MB", "/speech/text", "a" * 1_000_000),
                                  ("ROS action line of 100,000 characters", "/siftom/actions",
                                   "walk(human, " + "k" * 100_000 + ")")):
            got = send(topic, data)
            rows.append(HostileRow(name, f"ROS {topic}", 422 if got.refused else 200 if got.decided else 0,
                                   got.seconds, got.said[:160], None, 0, expect=422))
        got = send("/speech/text", SPOKEN)
        rows.append(HostileRow("ROS instruction after them", "ROS /speech/text", 200 if got.decided else 0,
                               got.seconds, got.said[:160], None, 0, expect=200, within_s=5.0))
    return rows


async def _all(url: str, token: str | None) -> list[HostileRow]:
    import httpx

    headers = {"Authorization": f"Bearer {token}"} if token else {}
    rows = await _hostile(url, headers)
    async with httpx.AsyncClient(base_url=url, headers=headers, timeout=120) as client:
        rows += await _stream_rows(client, url, headers)
        rows += await _header_rows(client, token)  # last: the bench's address is throttled for a minute after
    return rows


def run_hostile_bench(url: str | None = None, token: str | None = None) -> HostileResult:
    """Each hostile input once, while ``/healthz`` is polled every 10 ms: status, seconds to the
    refusal, what it said, and the slowest ``/healthz`` meanwhile. Without ``url`` a server is
    started on loopback with a fresh token (so the header cases run)."""
    where = Machine.here()
    with contextlib.ExitStack() as stack:
        if url is None:
            token = token or secrets.token_urlsafe(32)  # what ``siftom serve`` makes: 43 URL-safe characters
            url = stack.enter_context(local_server(token))
        rows = asyncio.run(_all(url, token))
    rows += _ros_rows()
    return HostileResult(where, tuple(rows), all(r.meets() for r in rows if r.ran))
