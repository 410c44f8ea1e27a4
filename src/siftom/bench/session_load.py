"""Load test of the session API: many robots at once, each streaming actions, then speaking.

``run_session_load(sessions=50, actions=10)`` creates ``sessions`` sessions (worlds of the
built-in household scenarios that have at least ``actions`` recorded actions, exported as world
JSON), then every session, concurrently, streams its scenario's first ``actions`` actions one
request at a time (odd sessions as VirtualHome script lines, even ones in siftom's form) and
sends one instruction. ``interval`` seconds pass between a session's requests (default 1 s: a
person acts about once a second, and a robot reports each action as it sees it); sessions start
at seeded random offsets within the first interval, as robots are not synchronised. With
``interval=0`` every session sends back to back, all 50 in flight at once: the harshest case,
which measures queueing rather than the service (latency ~ sessions x CPU per request).
Afterwards every session is read back: an action or an answer missing there counts as lost.
Creation is measured apart from the streamed requests.

Without ``url`` the server is started as its own process (``python -m siftom.cli serve``), as a
robot's server would run, so the client's work does not share the server's interpreter (the bench
never imports the service; it speaks HTTP to it, as :mod:`siftom.bench.robots` does); the
server's CPU time per streamed request is reported too (from /proc on Linux): unlike latency it
does not grow when other programs compete for the cores.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.machine import Machine
from siftom.errors import SiftomError

TARGET_P99_MS = 200.0


@dataclass(frozen=True)
class SessionLoadResult:
    """What the session load test measured (latencies in ms, over all streamed requests); ``machine``:
    where the client ran and its load when the test began."""

    sessions: int
    actions_per_session: int
    interval_s: float
    requests: int
    errors: int
    lost: int
    seconds: float
    rps: float
    p50_ms: float
    p90_ms: float
    p99_ms: float
    max_ms: float
    actions_p99_ms: float
    instruction_p50_ms: float
    instruction_p99_ms: float
    create_p50_ms: float
    create_max_ms: float
    server_cpu_ms_per_request: float | None
    url: str
    machine: Machine = field(default_factory=Machine)

    def to_json(self) -> dict[str, Any]:
        return asdict(self) | {"machine": self.machine.to_json()}

    def meets(self, max_p99_ms: float = TARGET_P99_MS) -> bool:
        """The sessions target: no errors, nothing lost, p99 < 200 ms per streamed request."""
        return self.errors == 0 and self.lost == 0 and self.p99_ms < max_p99_ms

    def summary(self) -> str:
        """One line for the console: counts, latencies, creation and the server's CPU."""
        verdict = "meets" if self.meets() else "MISSES"
        return (f"{self.sessions} sessions x ({self.actions_per_session} actions + 1 instruction), interval "
                f"{self.interval_s:g} s: {self.requests - self.errors}/{self.requests} ok, {self.lost} lost, "
                f"{self.rps:.1f} req/s; latency p50 {self.p50_ms:.1f} ms, p90 {self.p90_ms:.1f} ms, "
                f"p99 {self.p99_ms:.1f} ms, max {self.max_ms:.1f} ms ({verdict} p99 < 200 ms, nothing lost); "
                f"p99 actions {self.actions_p99_ms:.1f} ms, instructions p50 {self.instruction_p50_ms:.1f} ms, "
                f"p99 {self.instruction_p99_ms:.1f} ms; creating a session: p50 {self.create_p50_ms:.1f} ms, "
                f"max {self.create_max_ms:.1f} ms; server CPU {self.server_cpu_ms_per_request} ms per streamed "
                f"request{self.machine.summary()}")


def _vh(world: Any, a: Any) -> str:
    if a.kind == "walk":
        return f"[Walk] <{world.places[a.place].name}> (0)"
    if a.kind in ("open", "close"):
        return f"[{a.kind.title()}] <{world.places[a.place].name}> (0)"
    if a.kind == "grab":
        return f"[Grab] <{world.items[a.obj].name}> (0)"
    return f"[PutBack] <{world.items[a.obj].name}> (0) <{world.places[a.place].name}> (0)"


@dataclass(frozen=True)
class SessionWork:
    """What one session of the load test sends: its world JSON, action lines and transcript."""

    world: dict[str, Any]
    actions: tuple[str, ...]
    transcript: str


def workload(sessions: int, actions: int) -> list[SessionWork]:
    """Per session: the world JSON, the action lines and the transcript."""
    from siftom.scenarios.base import get_scenario
    from siftom.world.domains import household
    from siftom.world.io import scene_to_json

    pool = [get_scenario(f"household-table-v0/{i}") for i in range(household.N_FIXED)]
    pool = [sc for sc in pool if len(sc.actions) >= actions]
    if not pool:
        raise SiftomError(f"no built-in scenario has {actions} actions; ask for at most 12")
    out = []
    for k in range(sessions):
        sc = pool[k % len(pool)]
        acts = sc.actions[:actions]
        lines = [_vh(sc.world, a) if k % 2 else sc.world.format_action(a) for a in acts]
        cls = sc.command.obj_class
        out.append(SessionWork(scene_to_json(sc.world, sc.start, sc.goals, sc.verb, household.DOORS),
                               tuple(lines), f"could you bring me the {cls}s"))
    return out


def _cpu_seconds(pid: int | None) -> float | None:
    """utime + stime of a process (Linux /proc), or None."""
    if pid is None:
        return None
    try:
        import os

        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def free_port() -> int:
    """A loopback TCP port free right now."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def serve_in_process(startup_timeout: float = 90.0, args: Sequence[str] = (),
                     src: str | Path | None = None) -> Iterator[tuple[str, int]]:
    """``siftom serve [args]`` on a free loopback port in a fresh data folder, as its own process
    (the bench does not import the service: it talks to it over HTTP); yields (url, pid).
    ``src``: the source folder to serve from (default: this one's), e.g. another version's, to
    measure both in one run."""
    import os
    import shutil
    import subprocess
    import sys
    import tempfile

    import httpx

    port = free_port()
    folder = tempfile.mkdtemp(prefix="siftom-load-")
    src = str(src if src is not None else Path(__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    log = Path(folder) / "serve.log"
    with log.open("wb") as err:
        proc = subprocess.Popen([sys.executable, "-m", "siftom.cli", "serve", "--host", "127.0.0.1",
                                 "--port", str(port), "--data-dir", str(Path(folder) / "data"), *args],
                                env=env, stdout=subprocess.DEVNULL, stderr=err)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + startup_timeout
        while True:
            if proc.poll() is not None or time.monotonic() > deadline:
                tail = log.read_text(errors="replace")[-400:].strip()
                raise SiftomError(f"siftom serve did not start on port {port} within {startup_timeout:g} s"
                                  + (f": {tail}" if tail else ""))
            try:
                if httpx.get(f"{url}/healthz", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                time.sleep(0.2)
        yield url, proc.pid
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(folder, ignore_errors=True)


async def _run(url: str, work: list[SessionWork], interval: float, timeout: float, pid: int | None = None,
               seed: int = 0) -> tuple[list[tuple[str, float]], list[float], int, int, float, float | None]:
    import httpx

    n = len(work)
    limits = httpx.Limits(max_connections=n, max_keepalive_connections=n)
    async with httpx.AsyncClient(base_url=url, timeout=timeout, limits=limits) as client:
        async def create(w: SessionWork) -> tuple[str | None, float]:
            t0 = time.perf_counter()
            r = await client.post("/v1/sessions", json={"world": w.world})
            return (r.json()["id"] if r.status_code == 201 else None), time.perf_counter() - t0

        made = await asyncio.gather(*(create(w) for w in work))
        create_lat = [t for _sid, t in made]
        lat: list[tuple[str, float]] = []
        errors = sum(1 for sid, _t in made if sid is None)
        answers: dict[str, str] = {}

        offsets = np.random.default_rng(seed).uniform(0.0, interval, size=len(work))

        async def stream(sid: str, w: SessionWork, offset: float) -> None:
            nonlocal errors
            reqs: list[tuple[str, dict[str, Any]]] = [("actions", {"actions": [line]}) for line in w.actions]
            reqs.append(("instruction", {"transcript": w.transcript}))
            await asyncio.sleep(offset)
            for k, (path, body) in enumerate(reqs):
                if interval and k:
                    await asyncio.sleep(interval)
                t0 = time.perf_counter()
                try:
                    r = await client.post(f"/v1/sessions/{sid}/{path}", json=body)
                    ok = r.status_code == 200
                    if ok and path == "instruction":
                        answers[sid] = r.json()["command"]
                except httpx.HTTPError:
                    ok = False
                lat.append((path, time.perf_counter() - t0))
                errors += not ok

        t0 = time.perf_counter()
        cpu0 = _cpu_seconds(pid)
        await asyncio.gather(*(stream(sid, w, off) for (sid, _t), w, off in zip(made, work, offsets, strict=True)
                               if sid))
        secs = time.perf_counter() - t0
        cpu1 = _cpu_seconds(pid)
        cpu = (cpu1 - cpu0) / max(len(lat), 1) * 1000.0 if cpu0 is not None and cpu1 is not None else None
        lost = 0
        for (sid, _t), w in zip(made, work, strict=True):
            if sid is None:
                continue
            view = (await client.get(f"/v1/sessions/{sid}")).json()
            last = view.get("last_instruction") or {}
            lost += (view.get("n_actions", 0) < len(w.actions)) + (last.get("command") != answers.get(sid))
            await client.delete(f"/v1/sessions/{sid}")
        return lat, create_lat, errors, lost, secs, cpu


def run_session_load(sessions: int = 50, actions: int = 10, interval: float = 1.0, url: str | None = None,
                     timeout: float = 60.0, warmup: bool = True, seed: int = 0,
                     _pid: int | None = None) -> SessionLoadResult:
    """Run the session load test (see module doc); None ``url`` starts ``siftom serve`` on loopback."""
    if sessions < 1 or actions < 1 or interval < 0:
        raise SiftomError("sessions and actions must be >= 1 and interval >= 0")
    if url is None:
        with serve_in_process() as (base, pid):
            return run_session_load(sessions, actions, interval, base, timeout, warmup, seed, pid)
    work = workload(sessions, actions)
    if warmup:  # load the likelihood's lexicon and the planner once, unmeasured
        asyncio.run(_run(url, work[:1], 0.0, timeout))
    where = Machine.here()
    lat, create_lat, errors, lost, secs, cpu = asyncio.run(_run(url, work, interval, timeout, _pid, seed))
    ms = np.asarray([t for _p, t in lat] or [0.0]) * 1000.0
    act = np.asarray([t for p, t in lat if p == "actions"] or [0.0]) * 1000.0
    ins = np.asarray([t for p, t in lat if p == "instruction"] or [0.0]) * 1000.0
    cms = np.asarray(create_lat) * 1000.0
    p50, p90, p99 = (float(np.percentile(ms, q)) for q in (50, 90, 99))
    return SessionLoadResult(sessions, actions, interval, len(lat), errors, lost, round(secs, 3),
                             round(len(lat) / secs, 1) if secs else 0.0, round(p50, 1), round(p90, 1),
                             round(p99, 1), round(float(ms.max()), 1), round(float(np.percentile(act, 99)), 1),
                             round(float(np.percentile(ins, 50)), 1), round(float(np.percentile(ins, 99)), 1),
                             round(float(np.percentile(cms, 50)), 1),
                             round(float(cms.max()), 1), round(cpu, 2) if cpu is not None else None, url, where)
