"""The load tools of ``siftom bench serve`` (siftom.bench.loadtest, siftom.bench.session_load):
their request bodies, their counts against a running server, and (slow) a server of their own
started as a process."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from siftom.bench.loadtest import DEFAULT_BODIES, LoadResult, run_load_test  # noqa: E402
from siftom.bench.session_load import SessionLoadResult, serve_in_process  # noqa: E402
from siftom.errors import SiftomError  # noqa: E402


def test_the_default_bodies_are_infer_requests_the_service_accepts():
    from siftom.service.schemas import InferRequest

    for body in DEFAULT_BODIES:
        assert InferRequest.model_validate(body).model_dump(exclude_unset=True) == body


def test_the_load_test_counts_requests_against_a_running_server(tmp_path):
    from siftom.service.app import create_app
    from siftom.service.local_server import serve_in_thread

    app = create_app(tmp_path / "data")
    try:
        with serve_in_thread(app) as url:
            res = run_load_test(requests=6, concurrency=2, warmup=1, url=url)
    finally:
        app.state.runtime.close()
    assert (res.requests, res.ok, res.errors, res.concurrency, res.url) == (6, 6, 0, 2, url)
    assert res.p50_ms <= res.p90_ms <= res.p99_ms <= res.max_ms
    assert set(json.loads(json.dumps(res.to_json()))) == {
        "requests", "ok", "errors", "concurrency", "seconds", "rps", "p50_ms", "p90_ms", "p99_ms", "max_ms", "url",
        "machine"}
    assert res.summary().startswith("6/6 ok, concurrency 2") and "req/s" in res.summary()
    # where it was measured: the CPUs, the processor and the load as the measured phase began
    m = res.to_json()["machine"]
    assert m["cpus"] >= 1 and m["processor"] and len(m["load_avg_before"]) == 3
    assert f"{m['cpus']} CPUs ({m['processor']}), load " in res.summary()


def test_bad_budgets_are_refused_before_any_server_starts():
    with pytest.raises(SiftomError, match="requests and concurrency"):
        run_load_test(requests=0)


def test_the_summaries_say_whether_the_targets_are_met():
    fast = LoadResult(100, 100, 0, 8, 1.0, 100.0, 5.0, 8.0, 9.0, 10.0, "http://x")
    assert fast.meets() and "meets >= 50 req/s" in fast.summary()
    assert "meets" not in fast.summary(verdict=False)
    slow = SessionLoadResult(2, 1, 0.0, 4, 0, 1, 1.0, 4.0, 1, 2, 300, 300, 1, 1, 1, 1, 1, None, "http://x")
    assert not slow.meets() and "MISSES p99 < 200 ms" in slow.summary() and "1 lost" in slow.summary()


def test_a_server_that_cannot_start_is_an_error_naming_why():
    with pytest.raises(SiftomError, match="did not start"), \
            serve_in_process(startup_timeout=60, args=("--audio-workers", "-1")):
        pass


@pytest.mark.slow
def test_the_load_test_starts_siftom_serve_as_its_own_process():
    from click.testing import CliRunner

    from siftom.cli import root

    r = CliRunner().invoke(root, ["bench", "serve", "-n", "4", "-c", "2", "--warmup", "1", "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["ok"] == 4 and res["url"].startswith("http://127.0.0.1:") and "meets_target" in res
