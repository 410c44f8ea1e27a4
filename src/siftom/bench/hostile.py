"""``siftom bench hostile``: requests built to exhaust the service (huge worlds, huge names), each
sent once to a server while ``/healthz`` is polled; each must be refused at once with a 4xx naming
its limit, and the server must stay responsive meanwhile."""

from __future__ import annotations

import asyncio
import contextlib
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


@dataclass(frozen=True)
class HostileRow:
    """One hostile request: what was sent, the answer's status, how long the refusal took, what it
    said, and the slowest of the ``/healthz`` polls (and their number) meanwhile."""

    input: str
    path: str
    status: int
    seconds: float
    detail: str
    healthz_max_ms: float | None
    healthz_n: int

    def to_json(self) -> dict[str, Any]:
        """The row's entry in ``results/service/hostile.json``."""
        return {"input": self.input, "path": self.path, "status": self.status, "seconds": self.seconds,
                "detail": self.detail, "healthz_max_ms": self.healthz_max_ms, "healthz_n": self.healthz_n}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> HostileRow:
        """Read :meth:`to_json`'s form."""
        return cls(data["input"], data.get("path", ""), data["status"], data["seconds"], data["detail"],
                   data.get("healthz_max_ms"), data.get("healthz_n", 0))

    def meets(self) -> bool:
        """A 4xx within a second, ``/healthz`` within 100 ms meanwhile."""
        return 400 <= self.status < 500 and self.seconds < 1.0 and (self.healthz_max_ms or 0) < 100


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


def run_hostile_bench(url: str | None = None, token: str | None = None) -> HostileResult:
    """Each hostile request once, while ``/healthz`` is polled every 10 ms: status, seconds to the
    refusal, what it said, and the slowest ``/healthz`` meanwhile."""
    where = Machine.here()
    with contextlib.ExitStack() as stack:
        base = url or stack.enter_context(local_server(token))
        rows = asyncio.run(_hostile(base, {"Authorization": f"Bearer {token}"} if token else {}))
    return HostileResult(where, tuple(rows), all(r.meets() for r in rows))
