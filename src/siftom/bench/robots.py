"""``siftom bench robots``: several robots streaming into one server, with HTTP traffic beside them.

A ``siftom serve`` process is started on a free loopback port (or ``url`` names a running one).
First the idle ``POST /v1/infer`` latency is measured (transcripts, one at a time). Then ``streams``
sessions are created over the kitchen scenario (after one untimed instruction streamed to warm
the server up) and each streams its own recording through
``WS /v1/sessions/{id}/listen`` in 20 ms chunks at real-time pace (instructions from
:mod:`siftom.bench.stream` with pauses drawn per stream, starts staggered over the first
seconds; with ``burst`` every stream sends the same recording from the same instant, so the
speech of all streams ends at once), while ``/v1/infer`` is polled ``http_rps`` times a second. For every instruction the
delay is the time from the end of its speech (known from the recording) to the arrival of its
``decision`` (or ``no_speech``) event; an instruction without an event by the end of the stream
(plus ``grace_s``) is missed. The result names the machine and the load average beside the
figures; :meth:`ServeBenchResult.meets` checks the service's floors (every decision, p90 within
1 s of the end of speech, ``/v1/infer`` p90 within 3x idle).

The client is light (asyncio, no model), so it may run on the server's machine: its own CPU use is
reported (``client_cpu_s``).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.bench.machine import Machine
from siftom.errors import OptionsError, SiftomError

if TYPE_CHECKING:
    from siftom.bench.stream import SpokenInstruction

CHUNK_S = 0.02
INFER_BODY = {"scenario": "kitchen-cereal-v0", "transcript": "can you pass me the cereal"}


@dataclass(frozen=True)
class ServeBenchOptions:
    """What to run.

    Attributes:
        streams: sessions streaming at once.
        instructions: instructions per stream (at most 8).
        http_rps: ``/v1/infer`` requests a second during the streams.
        idle_requests: ``/v1/infer`` requests timed before the streams start.
        likelihood: the sessions' likelihood (None: the server's default).
        url: a running server (None: start ``siftom serve`` here).
        token: the server's token, if it has one.
        seed: pauses and starts.
        grace_s: how long after its stream ends an instruction may still be answered.
        in_process: also stream the first stream's recording through an in-process listener
            (``siftom bench stream``'s, the default likelihood) in the same run, for the ratio
            of the WebSocket's delay to it.
        burst: every stream sends the first stream's recording, all starting at once: their
            speech ends at the same instant (a lab of robots hearing one person, a noisy dinner).
    """

    streams: int = 8
    instructions: int = 4
    http_rps: float = 2.0
    idle_requests: int = 20
    likelihood: str | None = None
    url: str | None = None
    token: str | None = None
    seed: int = 0
    grace_s: float = 10.0
    in_process: bool = False
    burst: bool = False

    def __post_init__(self) -> None:
        if not 1 <= self.streams <= 64:
            raise OptionsError(f"streams must be 1-64, got {self.streams}")
        if not 1 <= self.instructions <= 8:
            raise OptionsError(f"instructions must be 1-8, got {self.instructions}")
        if not 0 <= self.http_rps <= 100 or self.idle_requests < 1 or self.grace_s <= 0:
            raise OptionsError("http_rps must be 0-100, idle_requests >= 1 and grace_s > 0")


@dataclass
class StreamOutcome:
    """One stream: each instruction's delay (s, None when missed) and what was decided."""

    session: str
    delays_s: list[float | None] = field(default_factory=list)
    events: list[str] = field(default_factory=list)
    timings: list[dict[str, Any]] = field(default_factory=list)  # each answer's own timings and ``degraded``
    closed: str = ""


@dataclass
class ServeBenchResult:
    """Per stream and overall: decisions, delays, HTTP percentiles, machine and load."""

    options: dict[str, Any]
    machine: Machine
    idle_infer_ms: dict[str, float]
    load_infer_ms: dict[str, float]
    infer_errors: int
    streams: list[dict[str, Any]]
    expected: int
    answered: int
    delay_p50_s: float | None
    delay_p90_s: float | None
    load_avg_after: tuple[float, float, float]
    client_cpu_s: float
    wall_s: float
    in_process: dict[str, Any] | None = None  # the same recording through an in-process listener

    def to_json(self) -> dict[str, Any]:
        """The ``results/service/robots-*.json`` form."""
        return asdict(self) | {"machine": self.machine.to_json()}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> ServeBenchResult:
        """Read a ``results/service/robots-*.json`` file's content."""
        return cls(options=dict(data["options"]), machine=Machine.from_json(data.get("machine")),
                   idle_infer_ms=dict(data["idle_infer_ms"]), load_infer_ms=dict(data["load_infer_ms"]),
                   infer_errors=int(data.get("infer_errors", 0)), streams=list(data.get("streams", [])),
                   expected=int(data["expected"]), answered=int(data["answered"]),
                   delay_p50_s=data.get("delay_p50_s"), delay_p90_s=data.get("delay_p90_s"),
                   load_avg_after=tuple(data.get("load_avg_after") or (0.0, 0.0, 0.0)),
                   client_cpu_s=float(data.get("client_cpu_s", 0.0)), wall_s=float(data.get("wall_s", 0.0)),
                   in_process=data.get("in_process"))

    def meets(self) -> bool:
        """Every instruction answered, delay p90 <= 1 s, ``/v1/infer`` p90 <= 3x idle."""
        return (self.answered == self.expected and self.delay_p90_s is not None and self.delay_p90_s <= 1.0
                and self.load_infer_ms["p90"] <= 3 * self.idle_infer_ms["p90"])


def _pcts(ms: list[float]) -> dict[str, float]:
    if not ms:
        return {"n": 0, "p50": float("nan"), "p90": float("nan"), "max": float("nan")}
    a = np.asarray(ms)
    return {"n": len(ms), "p50": round(float(np.percentile(a, 50)), 1), "p90": round(float(np.percentile(a, 90)), 1),
            "max": round(float(a.max()), 1)}


@contextlib.contextmanager
def local_server(token: str | None) -> Any:
    """``siftom serve`` on a free loopback port (with ``token``, if given); yields its URL once
    ``/healthz`` answers."""
    import socket

    import httpx

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:  # a port free right now
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    cmd = [sys.executable, "-m", "siftom.cli", "serve", "--host", "127.0.0.1", "--port", str(port)]
    env = {**os.environ, "SIFTOM_TOKEN": token} if token else None
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            if proc.poll() is not None:
                err = proc.stderr.read().decode(errors="replace")[-400:] if proc.stderr else ""
                raise SiftomError(f"siftom serve exited with {proc.returncode}: {err}")
            with contextlib.suppress(httpx.HTTPError):
                if httpx.get(f"{url}/healthz", timeout=1).status_code == 200:
                    break
            if time.monotonic() > deadline:
                raise SiftomError("siftom serve did not answer /healthz within 120 s")
            time.sleep(0.25)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()


async def _infer_times(client: Any, n: int | None, rps: float, stop: asyncio.Event | None) -> tuple[list[float], int]:
    """``n`` sequential requests (idle), or one every 1/rps seconds until ``stop`` (under load)."""
    ms: list[float] = []
    errors = 0
    k = 0
    while (n is not None and k < n) or (stop is not None and not stop.is_set()):
        t0 = time.perf_counter()
        try:
            r = await client.post("/v1/infer", json=INFER_BODY)
            errors += r.status_code != 200
        except Exception:
            errors += 1
        ms.append((time.perf_counter() - t0) * 1000)
        k += 1
        if stop is not None:  # paced: the next request 1/rps seconds after this one began
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), max(0.0, 1 / rps - (time.perf_counter() - t0)))
    return ms, errors


async def _one_stream(url: str, headers: dict[str, str], session: str, audio: np.ndarray,
                      truths: Sequence[SpokenInstruction], start_delay: float, grace_s: float) -> StreamOutcome:
    import websockets

    out = StreamOutcome(session)
    ends = [t.end_s for t in truths]
    arrivals: list[float] = []
    await asyncio.sleep(start_delay)
    ws_url = url.replace("http://", "ws://") + f"/v1/sessions/{session}/listen"
    pcm = (np.clip(audio, -1, 1) * 32767).astype("<i2").tobytes()
    step = int(CHUNK_S * 16000) * 2
    async with websockets.connect(ws_url, additional_headers=headers, max_size=2**22) as ws:
        t0 = time.monotonic()

        async def read() -> None:
            async for msg in ws:
                if isinstance(msg, bytes):
                    continue
                ev = json.loads(msg)
                kind = ev.get("event", "")
                if kind in ("decision", "no_speech", "error"):
                    arrivals.append(time.monotonic() - t0)
                    out.events.append(kind if kind != "decision" else f"{ev.get('action', '')}")
                    out.timings.append({**ev.get("timings", {}), "degraded": ev.get("degraded", "")})

        reader = asyncio.create_task(read())
        for k in range(0, len(pcm), step):
            due = t0 + (k // step + 1) * CHUNK_S
            await asyncio.sleep(max(0.0, due - time.monotonic()))
            await ws.send(pcm[k:k + step])
        await ws.send(json.dumps({"type": "end"}))
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(reader, grace_s)
        reader.cancel()
        out.closed = str(ws.close_code) if ws.close_code is not None else "open"
    out.delays_s = match_delays(ends, arrivals)
    return out


def match_delays(ends: list[float], arrivals: list[float]) -> list[float | None]:
    """Each instruction's delay: an answer (stream seconds) goes to the earliest instruction that
    ended before it and has none yet; an instruction left without one is missed (None)."""
    free = list(range(len(ends)))
    delays: list[float | None] = [None] * len(ends)
    for t in sorted(arrivals):
        cand = [i for i in free if ends[i] <= t]
        if cand:
            i = cand[0]
            delays[i] = round(float(t - ends[i]), 3)
            free.remove(i)
    return delays


async def _run(opts: ServeBenchOptions, url: str) -> tuple[dict[str, float], dict[str, float], int,
                                                           list[StreamOutcome], tuple[np.ndarray, list[SpokenInstruction]]]:
    import httpx

    from siftom.bench.stream import StreamBenchOptions, build_stream

    headers = {"Authorization": f"Bearer {opts.token}"} if opts.token else {}
    rng = np.random.default_rng(opts.seed)
    async with httpx.AsyncClient(base_url=url, headers=headers, timeout=60) as client:
        idle, _ = await _infer_times(client, opts.idle_requests, 0, None)
        sessions, audios, truths = [], [], []
        for k in range(opts.streams):
            r = await client.post("/v1/sessions/from-scenario", json={"scenario": "kitchen-cereal-v0"})
            if r.status_code != 201:
                raise SiftomError(f"could not create a session: {r.status_code} {r.text[:200]}")
            sessions.append(r.json()["id"])
            x, tr = build_stream(StreamBenchOptions(seed=opts.seed * 1000 + k, quick=opts.instructions <= 4))
            keep = tr[:opts.instructions]
            end = int((keep[-1].end_s + 1.0) * 16000)
            audios.append(x[:end])
            truths.append(keep)
        # warm-up (not timed): one instruction streamed, so the recogniser, its worker and Whisper are
        # built, as on a server that has been answering for a while
        r = await client.post("/v1/sessions/from-scenario", json={"scenario": "kitchen-cereal-v0"})
        if r.status_code == 201:
            warm = r.json()["id"]
            x, tr = build_stream(StreamBenchOptions(seed=opts.seed, quick=True))
            await _one_stream(url, headers, warm, x[:int((tr[0].end_s + 1.0) * 16000)], tr[:1], 0.0, opts.grace_s)
            await client.delete(f"/v1/sessions/{warm}")
        stop = asyncio.Event()
        poll = asyncio.create_task(_infer_times(client, None, opts.http_rps, stop)) if opts.http_rps > 0 else None
        starts = rng.uniform(0, 2.0, opts.streams)
        if opts.burst:  # one recording, one start: every stream's speech ends at the same instant
            audios, truths, starts = [audios[0]] * opts.streams, [truths[0]] * opts.streams, np.zeros(opts.streams)
        outcomes = await asyncio.gather(*(_one_stream(url, headers, s, a, t, float(d), opts.grace_s)
                                          for s, a, t, d in zip(sessions, audios, truths, starts, strict=True)))
        stop.set()
        load, errors = await poll if poll is not None else ([], 0)
        for s in sessions:
            with contextlib.suppress(httpx.HTTPError):
                await client.delete(f"/v1/sessions/{s}")
    return _pcts(idle), _pcts(load), errors, list(outcomes), (audios[0], truths[0])


def run_serve_bench(opts: ServeBenchOptions | None = None) -> ServeBenchResult:
    """Run the benchmark (module doc)."""
    opts = opts or ServeBenchOptions()
    where = Machine.here()
    t0, c0 = time.perf_counter(), time.process_time()
    with contextlib.ExitStack() as stack:
        url = opts.url or stack.enter_context(local_server(opts.token))
        idle, load, errors, outcomes, (audio0, truths0) = asyncio.run(_run(opts, url))
    local = None
    if opts.in_process:
        from siftom.bench.stream import _stream_delays

        got = _stream_delays("auto", audio0, truths0)
        local = {"p50_s": got["p50_s"], "p90_s": got["p90_s"], "answered": got["answered"]}
    delays = [d for o in outcomes for d in o.delays_s if d is not None]
    expected = sum(len(o.delays_s) for o in outcomes)
    return ServeBenchResult(
        options=asdict(opts) | {"token": "set" if opts.token else None}, machine=where, idle_infer_ms=idle,
        load_infer_ms=load, infer_errors=errors,
        streams=[{"session": o.session, "delays_s": o.delays_s, "events": o.events, "closed": o.closed,
                  "timings": o.timings}
                 for o in outcomes],
        expected=expected, answered=len(delays),
        delay_p50_s=round(statistics.median(delays), 3) if delays else None,
        delay_p90_s=round(float(np.percentile(delays, 90)), 3) if delays else None,
        load_avg_after=tuple(round(x, 2) for x in os.getloadavg()),  # type: ignore[arg-type]
        client_cpu_s=round(time.process_time() - c0, 2), wall_s=round(time.perf_counter() - t0, 1), in_process=local)
