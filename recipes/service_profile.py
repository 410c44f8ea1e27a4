"""Where a ``POST /v1/infer`` request spends its time, and the same against another source tree.

The app (``siftom.service.app.create_app``) is called in this process as an ASGI application on
the load test's own request set (``siftom bench serve``'s bodies), its CPU work run inline (no
thread hop), with timers around the parts a request passes through:

* middleware: everything outside the endpoint (Host/Origin/token guard, body limit, security
  headers, routing, dependencies);
* validation: ``InferRequest.model_validate_json``;
* observer: ``Observer.answer`` without its decision (the likelihood and the posterior);
* decision: ``Observer.decide`` (the decision rule, its question valuing included);
* reply: ``Runtime.infer`` around the answer (the answer's JSON, the clarification, the plan);
* serialisation: ``JSONResponse.render`` (the JSON bytes).

Each figure is CPU time of the one thread that runs the request (``time.thread_time``: on a
machine shared with other work it leaves out the time spent waiting for a core), the median per
request over the rounds (each round the mean over its requests); ``wall`` is the request's wall
time. Children run with one BLAS thread (``OMP_NUM_THREADS=1``).
With ``--against SRC`` the rounds alternate between this tree and the tree at ``SRC`` (a
``src`` folder, e.g. of ``git worktree add /tmp/ref REF``), each round a fresh process, and the
ratios this/against are printed beside the figures, so both are measured under the same load.
``--http N`` also starts ``siftom serve`` from each tree and alternates N-request load tests
(``siftom bench serve``'s, 8 in flight) between the two servers.

    python recipes/service_profile.py [--rounds 5] [--requests 120] [--against /tmp/ref/src]
                                      [--http 400] [--json]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parents[1] / "src"
PHASES = ("wall", "total", "middleware", "validation", "observer", "decision", "reply", "serialisation")
BODIES: tuple[dict[str, Any], ...] = (  # the load test's (siftom.bench.loadtest.DEFAULT_BODIES)
    {"scenario": "kitchen-cereal-v0", "transcript": "can you pass me the cereal"},
    {"scenario": "kitchen-cereal-v0", "transcript": "pass me the sugar"},
    {"scenario": "household-table-v0/3", "transcript": "bring me the forks"},
    {"scenario": "household-table-v0/0", "transcript": "could you get the bowls"},
    {"scenario": "kitchen-v0/2", "transcript": "get me the milk"},
    {"scenario": "kitchen-cereal-v0", "nbest": [{"text": "pass me the see real", "score": -3.0},
                                                 {"text": "pass me the sugar", "score": -4.0}]},
)


class Timers:
    """CPU seconds of this thread inside wrapped callables, by label (nested calls counted where they run)."""

    def __init__(self) -> None:
        self.spent: dict[str, float] = {}

    def wrap(self, owner: Any, name: str, label: str) -> None:
        fn = getattr(owner, name)
        raw = owner.__dict__.get(name)
        spent = self.spent

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + time.thread_time() - t0

        if isinstance(raw, classmethod):
            setattr(owner, name, classmethod(lambda cls, *a, **k: timed(*a, **k)))
        else:
            setattr(owner, name, timed)

    def wrap_async(self, owner: Any, name: str, label: str) -> None:
        fn: Callable[..., Any] = getattr(owner, name)
        spent = self.spent

        async def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.thread_time()
            try:
                return await fn(*args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + time.thread_time() - t0

        setattr(owner, name, timed)


def _scope(length: int) -> dict[str, Any]:
    return {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST", "scheme": "http",
            "path": "/v1/infer", "raw_path": b"/v1/infer", "query_string": b"", "root_path": "",
            "headers": [(b"host", b"localhost:8000"), (b"content-type", b"application/json"),
                        (b"content-length", str(length).encode())],
            "client": ("127.0.0.1", 50000), "server": ("127.0.0.1", 8000), "state": {}}


async def _post(app: Any, body: bytes) -> bytes:
    """One request through the whole app; its response body."""
    given = False

    async def receive() -> dict[str, Any]:
        nonlocal given
        if not given:
            given = True
            return {"type": "http.request", "body": body, "more_body": False}
        await asyncio.sleep(3600)  # the client stays connected until the answer is sent
        return {"type": "http.disconnect"}

    out: list[dict[str, Any]] = []

    async def send(message: dict[str, Any]) -> None:
        out.append(message)

    await app(_scope(len(body)), receive, send)
    if out[0].get("status") != 200:
        raise SystemExit(f"POST /v1/infer answered {out[0].get('status')}: {b''.join(m.get('body', b'') for m in out)!r}")
    return b"".join(m.get("body", b"") for m in out if m["type"] == "http.response.body")


def measure(requests: int, warmup: int = 3) -> dict[str, float]:
    """This process's tree: milliseconds per request by phase (module doc)."""
    import anyio.to_thread
    import fastapi.routing
    from starlette.responses import JSONResponse

    async def inline(fn: Callable[..., Any], *args: Any, **_: Any) -> Any:
        return fn(*args)

    anyio.to_thread.run_sync = inline  # type: ignore[assignment]  # CPU work in this thread: timed as it runs
    from siftom.observer import Observer
    from siftom.service import schemas
    from siftom.service.app import create_app
    from siftom.service.runtime import Runtime

    timers = Timers()
    timers.wrap_async(fastapi.routing, "run_endpoint_function", "endpoint")
    timers.wrap(schemas.InferRequest, "model_validate_json", "validation")
    timers.wrap(Observer, "answer", "answer")
    timers.wrap(Observer, "decide", "decision")
    timers.wrap(Runtime, "infer", "runtime")
    timers.wrap(JSONResponse, "render", "serialisation")
    app = create_app()
    encoded = [json.dumps(b).encode() for b in BODIES]

    async def run() -> tuple[float, float, int]:
        for _ in range(warmup):
            for b in encoded:
                await _post(app, b)
        timers.spent.clear()
        n = 0
        t0, c0 = time.perf_counter(), time.thread_time()
        while n < requests:
            await _post(app, encoded[n % len(encoded)])
            n += 1
        return time.perf_counter() - t0, time.thread_time() - c0, n

    try:
        wall, total, n = asyncio.run(run())
    finally:
        app.state.runtime.close()
    s = timers.spent
    ms = {
        "wall": wall,
        "total": total,
        "middleware": total - s.get("endpoint", 0.0),
        "validation": s.get("validation", 0.0),
        "observer": s.get("answer", 0.0) - s.get("decision", 0.0),
        "decision": s.get("decision", 0.0),
        "reply": s.get("runtime", 0.0) - s.get("answer", 0.0),
        "serialisation": s.get("serialisation", 0.0),
    }
    return {k: round(v / n * 1000.0, 3) for k, v in ms.items()}


def _round(src: Path, requests: int) -> dict[str, float]:
    """One round in a fresh process running the tree at ``src``."""
    env = {**os.environ, "PYTHONPATH": str(src), "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, __file__, "--worker", "--requests", str(requests)], env=env,
                         capture_output=True, text=True, timeout=600)
    if res.returncode != 0:
        raise SystemExit(f"the round on {src} failed: {res.stderr[-2000:]}")
    got: dict[str, float] = json.loads(res.stdout.strip().splitlines()[-1])
    return got


def _median(rows: list[dict[str, float]]) -> dict[str, float]:
    return {k: round(statistics.median(r[k] for r in rows), 3) for k in PHASES}


def http_rounds(trees: dict[str, Path], rounds: int, requests: int) -> dict[str, Any]:
    """``siftom serve`` from each tree, load tests alternating between them: req/s per round."""
    import contextlib

    from siftom.bench.loadtest import run_load_test
    from siftom.bench.session_load import serve_in_process

    rps: dict[str, list[float]] = {name: [] for name in trees}
    with contextlib.ExitStack() as stack:
        urls = {name: stack.enter_context(serve_in_process(src=src))[0] for name, src in trees.items()}
        for url in urls.values():  # caches filled before any measured round
            run_load_test(requests=60, concurrency=8, warmup=0, url=url)
        for _ in range(rounds):
            for name, url in urls.items():
                res = run_load_test(requests=requests, concurrency=8, warmup=0, url=url)
                if res.errors:
                    raise SystemExit(f"{res.errors} requests failed against {name}")
                rps[name].append(res.rps)
    return {name: {"rps": v, "median_rps": round(statistics.median(v), 1)} for name, v in rps.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--requests", type=int, default=120, help="requests per round")
    ap.add_argument("--against", type=Path, default=None, help="another tree's src folder, measured in turn")
    ap.add_argument("--http", type=int, default=0, help="also N requests per round against siftom serve of each")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(measure(a.requests)))
        return
    trees = {"this": HERE} if a.against is None else {"this": HERE, "against": a.against.resolve()}
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
    for _ in range(a.rounds):
        for name, src in trees.items():
            rows[name].append(_round(src, a.requests))
    from siftom.bench.machine import Machine

    out: dict[str, Any] = {"machine": Machine.here().to_json(), "requests_per_round": a.requests,
                           "rounds": a.rounds, "trees": {k: str(v) for k, v in trees.items()},
                           "ms_per_request": {name: _median(r) for name, r in rows.items()}}
    if a.http:
        out["http"] = http_rounds(trees, a.rounds, a.http)
    if a.json:
        print(json.dumps(out, indent=2))
        return
    m = out["machine"]
    print(f"{m['cpus']} CPUs ({m['processor']}), load {m['load_avg_before']}; {a.rounds} rounds x "
          f"{a.requests} requests; ms per POST /v1/infer (CPU of the request's thread; wall: its wall "
          "time; median of rounds)")
    this = out["ms_per_request"]["this"]
    other = out["ms_per_request"].get("against")
    print(f"{'phase':14s} {'this':>8s}" + (f" {'against':>8s} {'ratio':>6s}" if other else ""))
    for k in PHASES:
        line = f"{k:14s} {this[k]:8.3f}"
        if other:
            line += f" {other[k]:8.3f} {this[k] / other[k] if other[k] else float('nan'):6.2f}"
        print(line)
    if "http" in out:
        h = out["http"]
        line = "siftom serve, 8 in flight: " + ", ".join(f"{n} {v['median_rps']} req/s" for n, v in h.items())
        if "against" in h:
            line += f"; ratio {h['this']['median_rps'] / h['against']['median_rps']:.2f}"
        print(line)


if __name__ == "__main__":
    main()
