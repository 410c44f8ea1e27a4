"""A bounded load test of ``POST /v1/infer``: start ``siftom serve`` on loopback, send N requests.

``run_load_test`` sends ``requests`` inference requests (transcripts, cycling over a fixed set
of scenarios and instructions) with ``concurrency`` requests in flight, and reports the
throughput and latency percentiles. Budgets in (requests, concurrency, timeout), counters out.
:func:`audio_bodies` makes recordings of such instructions (synthetic speech) to send instead.

Without ``url`` the server is started as its own process (``python -m siftom.cli serve`` on a free
loopback port, :func:`siftom.bench.session_load.serve_in_process`): the bench never imports the
service, it speaks HTTP to it, as a robot would.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from siftom.bench.machine import Machine
from siftom.errors import SiftomError

# JSON bodies of POST /v1/infer (the service's InferRequest; tests/bench/test_load_tools.py checks them)
DEFAULT_BODIES: tuple[dict[str, Any], ...] = (
    {"scenario": "kitchen-cereal-v0", "transcript": "can you pass me the cereal"},
    {"scenario": "kitchen-cereal-v0", "transcript": "pass me the sugar"},
    {"scenario": "household-table-v0/3", "transcript": "bring me the forks"},
    {"scenario": "household-table-v0/0", "transcript": "could you get the bowls"},
    {"scenario": "kitchen-v0/2", "transcript": "get me the milk"},
    {"scenario": "kitchen-cereal-v0", "nbest": [{"text": "pass me the see real", "score": -3.0},
                                                 {"text": "pass me the sugar", "score": -4.0}]},
)


AUDIO_SENTENCES: tuple[tuple[str, str], ...] = (
    ("kitchen-cereal-v0", "can you pass me the cereal"),
    ("kitchen-cereal-v0", "pass me the sugar"),
    ("household-table-v0/3", "bring me the forks"),
    ("kitchen-v0/2", "get me the milk"),
)


@dataclass(frozen=True)
class AudioBody:
    """A multipart audio request: the form fields and the WAV bytes."""

    fields: dict[str, str]
    wav: bytes


def audio_bodies(likelihood: str = "phonetic", voice: str = "flite-slt") -> tuple[AudioBody, ...]:
    """One WAV per sentence of AUDIO_SENTENCES, spoken by ``voice``, for ``likelihood``."""
    from siftom.speech.audio import wav_bytes
    from siftom.speech.tts import synthesize

    return tuple(AudioBody({"scenario": sid, "likelihood": likelihood}, wav_bytes(synthesize(text, voice)))
                 for sid, text in AUDIO_SENTENCES)


@dataclass(frozen=True)
class LoadResult:
    """What the load test measured.

    Attributes:
        requests: requests sent; ok: of them answered 200; errors: the others.
        concurrency: requests in flight at once.
        seconds: wall time of the measured phase (after warm-up).
        rps: ok requests per second.
        p50_ms, p90_ms, p99_ms, max_ms: latency percentiles of all requests.
        url: where the server listened.
        machine: where the client ran and its load when the measured phase began (the
            server's machine too when it was started here).
    """

    requests: int
    ok: int
    errors: int
    concurrency: int
    seconds: float
    rps: float
    p50_ms: float
    p90_ms: float
    p99_ms: float
    max_ms: float
    url: str
    machine: Machine = field(default_factory=Machine)

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        return asdict(self) | {"machine": self.machine.to_json()}

    def meets(self, min_rps: float = 50.0, max_p99_ms: float = 200.0) -> bool:
        """Whether the service target is met (>= 50 req/s, p99 < 200 ms, no errors)."""
        return self.errors == 0 and self.rps >= min_rps and self.p99_ms < max_p99_ms

    def summary(self, verdict: bool = True) -> str:
        """One line for the console (``verdict``: whether the service target is met)."""
        met = f" ({'meets' if self.meets() else 'MISSES'} >= 50 req/s, p99 < 200 ms)" if verdict else ""
        return (f"{self.ok}/{self.requests} ok, concurrency {self.concurrency}, {self.seconds:.2f} s: "
                f"{self.rps:.1f} req/s; latency p50 {self.p50_ms:.1f} ms, p90 {self.p90_ms:.1f} ms, "
                f"p99 {self.p99_ms:.1f} ms, max {self.max_ms:.1f} ms{met}{self.machine.summary()}")


async def _drive(url: str, bodies: Sequence[dict[str, Any] | AudioBody], n: int, concurrency: int,
                 timeout: float) -> tuple[list[float], int, float]:
    import httpx

    latencies: list[float] = []
    ok = 0
    next_i = 0
    limits = httpx.Limits(max_connections=concurrency, max_keepalive_connections=concurrency)
    async with httpx.AsyncClient(base_url=url, timeout=timeout, limits=limits) as client:
        async def worker() -> None:
            nonlocal ok, next_i
            while next_i < n:
                i = next_i
                next_i += 1
                t0 = time.perf_counter()
                try:
                    body = bodies[i % len(bodies)]
                    if isinstance(body, AudioBody):
                        r = await client.post("/v1/infer", data=body.fields,
                                              files={"audio": ("say.wav", body.wav, "audio/wav")})
                    else:
                        r = await client.post("/v1/infer", json=body)
                    good = r.status_code == 200
                except httpx.HTTPError:
                    good = False
                latencies.append(time.perf_counter() - t0)
                ok += good

        t0 = time.perf_counter()
        await asyncio.gather(*(worker() for _ in range(concurrency)))
        return latencies, ok, time.perf_counter() - t0


def run_load_test(requests: int = 500, concurrency: int = 8, warmup: int = 20,
                  bodies: Sequence[dict[str, Any] | AudioBody] = DEFAULT_BODIES, url: str | None = None,
                  timeout: float = 30.0, audio_workers: int | None = None) -> LoadResult:
    """Send ``requests`` inferences with ``concurrency`` in flight; measure.

    Args:
        requests: measured requests (after ``warmup`` unmeasured ones that fill the caches and
            start the server's audio workers, if any).
        concurrency: requests in flight at once.
        url: an already running server; None starts ``siftom serve`` on a free loopback port
            (with ``--audio-workers audio_workers`` when given, else the settings' number).
        timeout: per-request client timeout in seconds.
    """
    if requests < 1 or concurrency < 1 or warmup < 0:
        raise SiftomError("requests and concurrency must be >= 1 and warmup >= 0")
    if url is None:
        from siftom.bench.session_load import serve_in_process

        args = ("--audio-workers", str(audio_workers)) if audio_workers is not None else ()
        with serve_in_process(args=args) as (base, _pid):
            return run_load_test(requests, concurrency, warmup, bodies, base, timeout)
    if warmup:
        asyncio.run(_drive(url, bodies, warmup, min(concurrency, warmup), timeout))
    where = Machine.here()
    lat, ok, secs = asyncio.run(_drive(url, bodies, requests, concurrency, timeout))
    ms = np.asarray(lat) * 1000.0
    p50, p90, p99 = (float(np.percentile(ms, q)) for q in (50, 90, 99))
    return LoadResult(requests, ok, requests - ok, concurrency, round(secs, 3), round(ok / secs, 1),
                      round(p50, 1), round(p90, 1), round(p99, 1), round(float(ms.max()), 1), url, where)
