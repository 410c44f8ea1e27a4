"""Service subcommands: ``serve`` and ``bench serve``."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import click

from siftom.backends.cli_options import flags_given, llm_config, llm_options
from siftom.errors import missing_extra
from siftom.speech.cli_options import whisper_model_option

if TYPE_CHECKING:
    from siftom.bench.runlock import RunLock


def _need_serve_extra() -> None:
    for module, package in (("fastapi", "fastapi"), ("uvicorn", "uvicorn"), ("multipart", "python-multipart")):
        try:
            __import__(module)
        except ModuleNotFoundError:
            raise missing_extra("serve", package) from None


def claim_data_dir(data_dir: str) -> RunLock:
    """Hold ``DATA_DIR/.siftom.lock`` for the life of this process: one server per data folder.

    Two servers on one folder would each cache sessions the other changes (answers from stale
    state, appends refused forever). The kernel drops the lock when the process dies, however
    it dies, so a restart after a crash is not refused.

    Raises:
        RunLockedError: another live process serves (or writes) the folder.
    """
    from siftom.bench.runlock import RunLock

    lock = RunLock(data_dir, fix="stop that server first, or give this one another --data-dir")
    lock.acquire()
    return lock


@click.command("serve")
@whisper_model_option
@click.option("--host", default="127.0.0.1", show_default=True, help="interface to listen on")
@click.option("--port", type=click.IntRange(1, 65535), default=8000, show_default=True, help="TCP port")
@click.option("--data-dir", type=click.Path(file_okay=False), default=None,
              help="the service's own folder (map cache, sessions.sqlite3); give the same folder after a "
                   "restart to continue the sessions; default: a fresh temporary folder")
@click.option("--max-sessions", type=click.IntRange(1, 1_000_000), default=1000, show_default=True,
              help="sessions stored at once (429 above)")
@click.option("--session-idle", type=click.FloatRange(1, 365 * 86400), default=86400.0, show_default=True,
              help="seconds without a change after which a session is deleted")
@click.option("--max-world-bytes", type=click.IntRange(1024, 64 * 2**20), default=2**20, show_default=True,
              help="largest world JSON in POST /v1/sessions (413 above)")
@click.option("--max-world-items", type=click.IntRange(1, 10_000), default=200, show_default=True,
              help="most objects a session's world may hold (422 above)")
@click.option("--max-session-actions", type=click.IntRange(1, 1_000_000), default=2000, show_default=True,
              help="most actions one session may observe (422 above)")
@click.option("--max-streams", type=click.IntRange(1, 10_000), default=8, show_default=True,
              help="WS /v1/sessions/{id}/listen streams open at once (more are closed with 1013)")
@click.option("--max-utterance", type=click.FloatRange(1, 120), default=15.0, show_default=True,
              help="seconds of speech after which a streamed utterance is cut and answered")
@click.option("--stream-idle", type=click.FloatRange(0.1, 86400), default=30.0, show_default=True,
              help="seconds without a message after which a stream is closed (4408)")
@llm_options
def serve_cmd(host: str, port: int, data_dir: str | None, max_sessions: int, session_idle: float,
              max_world_bytes: int, max_world_items: int, max_session_actions: int, max_streams: int,
              max_utterance: float, stream_idle: float,
              llm_backend: str | None, llm_base_url: str | None, llm_model: str | None) -> None:
    """Serve the HTTP API and the web page (open http://HOST:PORT/).

    The "llm" likelihood uses the --llm-* flags or SIFTOM_LLM_* (GET /healthz shows which).
    """
    _need_serve_extra()
    import uvicorn

    lock = claim_data_dir(data_dir) if data_dir is not None else None  # released when the process ends
    from siftom.service.app import create_app
    from siftom.service.runtime import ServiceSettings
    from siftom.service.sessions import SessionLimits

    limits = SessionLimits(max_sessions=max_sessions, idle_s=session_idle, max_world_bytes=max_world_bytes,
                           max_world_items=max_world_items, max_actions=max_session_actions)
    llm = llm_config(llm_backend, llm_base_url, llm_model) if flags_given(llm_backend, llm_base_url, llm_model) else None
    # a world of max_world_bytes must fit in a request body
    from siftom.service.stream_settings import StreamLimits

    stream = StreamLimits(max_streams=max_streams, max_utterance_s=max_utterance, max_idle_s=stream_idle)
    settings = ServiceSettings(sessions=limits, llm=llm, stream=stream,
                               max_body_bytes=max(ServiceSettings().max_body_bytes, max_world_bytes + 4096))
    click.echo(f"siftom: web page at http://{host}:{port}/ , API schema at /openapi.json", err=True)
    try:
        uvicorn.run(create_app(data_dir, settings), host=host, port=port, log_level="info")
    finally:
        if lock is not None:
            lock.release()


@click.command("serve")
@click.option("-n", "--requests", "n", type=click.IntRange(1, 100_000), default=500, show_default=True,
              help="measured requests")
@click.option("-c", "--concurrency", type=click.IntRange(1, 256), default=8, show_default=True,
              help="requests in flight at once")
@click.option("--warmup", type=click.IntRange(0, 10_000), default=20, show_default=True,
              help="unmeasured requests first (fill the caches)")
@click.option("--url", default=None, help="an already running server; default: start one on loopback")
@click.option("--json", "as_json", is_flag=True, help="print the result as JSON")
@click.option("--sessions", type=click.IntRange(1, 1000), default=None,
              help="load-test the session API instead: this many sessions at once, each streaming "
                   "--actions actions and one instruction")
@click.option("--actions", "n_actions", type=click.IntRange(1, 12), default=10, show_default=True,
              help="with --sessions: actions streamed per session, one request each")
@click.option("--interval", type=click.FloatRange(0, 10), default=1.0, show_default=True,
              help="with --sessions: seconds between one session's requests (a person acts about once a "
                   "second; 0: back to back, all sessions in flight at once)")
def bench_serve_cmd(n: int, concurrency: int, warmup: int, url: str | None, as_json: bool, sessions: int | None,
                    n_actions: int, interval: float) -> None:
    """Load-test POST /v1/infer with transcripts on loopback: req/s and latency percentiles
    (--sessions: the session API)."""
    _need_serve_extra()
    if sessions is not None:
        _bench_sessions(sessions, n_actions, interval, url, as_json)
        return
    from siftom.service.loadtest import run_load_test

    res = run_load_test(requests=n, concurrency=concurrency, warmup=warmup, url=url)
    if as_json:
        click.echo(json.dumps({**res.to_json(), "meets_target": res.meets()}, indent=2))
        return
    verdict = "meets" if res.meets() else "MISSES"
    click.echo(f"{res.ok}/{res.requests} ok, concurrency {res.concurrency}, {res.seconds:.2f} s: "
               f"{res.rps:.1f} req/s; latency p50 {res.p50_ms:.1f} ms, p90 {res.p90_ms:.1f} ms, "
               f"p99 {res.p99_ms:.1f} ms, max {res.max_ms:.1f} ms ({verdict} >= 50 req/s, p99 < 200 ms)")


def _bench_sessions(sessions: int, n_actions: int, interval: float, url: str | None, as_json: bool) -> None:
    from siftom.service.session_load import run_session_load

    res = run_session_load(sessions=sessions, actions=n_actions, interval=interval, url=url)
    if as_json:
        click.echo(json.dumps({**res.to_json(), "meets_target": res.meets()}, indent=2))
        return
    verdict = "meets" if res.meets() else "MISSES"
    click.echo(f"{res.sessions} sessions x ({res.actions_per_session} actions + 1 instruction), interval "
               f"{res.interval_s:g} s: {res.requests - res.errors}/{res.requests} ok, {res.lost} lost, "
               f"{res.rps:.1f} req/s; latency p50 {res.p50_ms:.1f} ms, p90 {res.p90_ms:.1f} ms, "
               f"p99 {res.p99_ms:.1f} ms, max {res.max_ms:.1f} ms ({verdict} p99 < 200 ms, nothing lost); "
               f"p99 actions {res.actions_p99_ms:.1f} ms, instructions p50 {res.instruction_p50_ms:.1f} ms, "
               f"p99 {res.instruction_p99_ms:.1f} ms; "
               f"creating a session: p50 {res.create_p50_ms:.1f} ms, max {res.create_max_ms:.1f} ms; server CPU "
               f"{res.server_cpu_ms_per_request} ms per streamed request")


def register(root: click.Group) -> None:
    """Add ``serve`` and ``bench serve`` to the root group."""
    root.add_command(serve_cmd)
    bench = root.commands.get("bench")
    if not isinstance(bench, click.Group):
        bench = click.Group("bench", help="Benchmarks.")
        root.add_command(bench)
    bench.add_command(bench_serve_cmd)
