"""``siftom bench serve``: load-test the HTTP API (POST /v1/infer, or the session API)."""

from __future__ import annotations

import dataclasses
import json

import click

from siftom.cli.records import pass_options
from siftom.cli.service import _need_serve_extra


@dataclasses.dataclass(frozen=True)
class BenchServeFlags:
    """The ``siftom bench serve`` flags as one record."""

    n: int
    concurrency: int
    warmup: int
    url: str | None
    as_json: bool
    sessions: int | None
    n_actions: int
    interval: float
    audio: bool
    likelihood: str
    audio_workers: int | None


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
@click.option("--audio", "audio", is_flag=True,
              help="send recordings (synthetic speech, multipart) instead of transcripts")
@click.option("--likelihood", default="phonetic", show_default=True,
              help="with --audio: the instruction likelihood the requests ask for (phonetic or acoustic)")
@click.option("--audio-workers", type=click.IntRange(0, 64), default=None,
              help="with --audio and no --url: the server's audio worker processes "
                   "(default: service.audio_workers of the settings)")
@pass_options(BenchServeFlags)
def bench_serve_cmd(args: BenchServeFlags) -> None:
    """Load-test POST /v1/infer with transcripts on loopback: req/s and latency percentiles
    (--audio: recordings; --sessions: the session API). Without --url, ``siftom serve`` is started
    as its own process on a free loopback port."""
    _need_serve_extra()
    if args.sessions is not None:
        from siftom.bench.session_load import run_session_load

        res_s = run_session_load(sessions=args.sessions, actions=args.n_actions, interval=args.interval, url=args.url)
        click.echo(json.dumps({**res_s.to_json(), "meets_target": res_s.meets()}, indent=2) if args.as_json
                   else res_s.summary())
        return
    from siftom.bench.loadtest import DEFAULT_BODIES, audio_bodies, run_load_test

    bodies = audio_bodies(args.likelihood) if args.audio else DEFAULT_BODIES
    res = run_load_test(requests=args.n, concurrency=args.concurrency, warmup=args.warmup, url=args.url,
                        bodies=bodies, audio_workers=args.audio_workers)
    click.echo(json.dumps({**res.to_json(), **({} if args.audio else {"meets_target": res.meets()})}, indent=2)
               if args.as_json else res.summary(verdict=not args.audio))


def register(root: click.Group) -> None:
    """Add ``bench serve`` to the ``bench`` group."""
    from siftom.cli.bench import bench_group

    bench_group.add_command(bench_serve_cmd)
