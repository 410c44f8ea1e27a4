"""``siftom bench inference|planner|latency|robots``: speed of inference, planning, audio to command,
and several robots streaming into one server."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import click

from siftom.bench.latency import SCENARIO, run_latency
from siftom.bench.speed import run_inference_bench, run_planner_bench
from siftom.cli.outputs import force_option, prepare_output
from siftom.cli.records import pass_options
from siftom.speech.cli_options import whisper_model_option


@click.command("inference")
@click.option("--json", "as_json", is_flag=True)
@click.option("--repeats", default=30, show_default=True)
def bench_inference_cmd(as_json: bool, repeats: int) -> None:
    """Inference speed: full p50, incremental update p50, scaling with goals (kitchen-v0)."""
    res = run_inference_bench(repeats)
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    click.echo(f"{res.scenario}: {res.num_items} objects, {res.num_goals} goals, "
               f"{res.num_actions} actions, {res.nbest}-best -> {res.command}")
    click.echo(f"  full inference p50      {res.p50_ms:.2f} ms")
    click.echo(f"  one-action update p50   {res.update_p50_ms:.2f} ms")
    click.echo(f"  posterior only p50      {res.posterior_p50_ms:.2f} ms")
    for goals, ms in res.scaling:
        click.echo(f"  {goals:>6} goals            {ms:.2f} ms")


@click.command("planner")
@click.option("--json", "as_json", is_flag=True)
@click.option("--repeats", default=20, show_default=True)
def bench_planner_cmd(as_json: bool, repeats: int) -> None:
    """Planner speed: Q* table for all goals x observed steps, A* nodes per second."""
    res = run_planner_bench(repeats)
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    click.echo(f"{res.scenario}: Q* for {res.num_goals} goals x {res.num_actions} steps x every action "
               f"= {res.q_values} values in {res.q_table_p50_ms:.2f} ms (p50) "
               f"= {res.v_per_second:.3g} values/s")
    click.echo(f"  A*: {res.astar_nodes_per_second:.0f} nodes expanded per second "
               f"({res.astar_nodes_expanded} nodes on 6 household scenarios)")
    click.echo(f"  one V*(s; g) with table build: {res.single_goal_value_ms:.3f} ms")


@click.command("latency")
@whisper_model_option
@click.option("--noise", default="babble", show_default=True, help="noise spec (siftom say --noise)")
@click.option("--snr", type=float, default=10.0, show_default=True)
@click.option("--repeats", type=int, default=3, show_default=True, help="timed runs per clip (all of them count)")
@click.option("--quick", is_flag=True, help="4 clips instead of 8")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def bench_latency_cmd(noise: str, snr: float, repeats: int, quick: bool, as_json: bool) -> None:
    """Time from an audio file (1-4 s) to the chosen command, per instruction likelihood."""
    res = run_latency(noise, snr, max(1, repeats), quick)
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    m = res.machine.to_json("latency")
    click.echo(f"clips: {list(res.clip_seconds)} s, {noise} at {snr:g} dB, {SCENARIO}; default likelihood "
               f"{res.default}; {m['cpus']} CPUs ({m['processor']}), load {m['load_1min']}")
    for lk, r in res.likelihoods.items():
        click.echo(f"{lk:9s} p50 {r.p50_s * 1000:.0f} ms  ratio_p50 {r.ratio_p50:.3f}  "
                   f"ratio_p90 {r.ratio_p90:.3f}  cpu_ratio_p50 {r.cpu_ratio_p50:.3f}  commands {list(r.commands)}")


@dataclasses.dataclass(frozen=True)
class RobotsBenchFlags:
    """The ``siftom bench robots`` flags as one record."""

    streams: int
    instructions: int
    http_rps: float
    url: str | None
    token: str | None
    seed: int
    burst: bool
    in_process: bool
    out: Path | None
    as_json: bool
    force: bool


@click.command("robots")
@click.option("--streams", type=click.IntRange(1, 64), default=8, show_default=True,
              help="sessions streaming real-time speech at once")
@click.option("--instructions", type=click.IntRange(1, 8), default=4, show_default=True,
              help="instructions per stream")
@click.option("--http-rps", type=click.FloatRange(0, 100), default=2.0, show_default=True,
              help="POST /v1/infer requests a second beside the streams")
@click.option("--url", default=None, help="a running server (default: start siftom serve on loopback)")
@click.option("--token", default=None, help="the running server's token")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True, help="pauses and stream starts")
@click.option("--burst", is_flag=True,
              help="every stream sends the same recording from the same instant: all speech ends at once")
@click.option("--in-process", is_flag=True,
              help="also stream the first recording through an in-process listener, for the WebSocket's overhead")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="also write the result as JSON here")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@force_option
@pass_options(RobotsBenchFlags)
def bench_robots_cmd(args: RobotsBenchFlags) -> None:
    """Several robots: N sessions stream real-time speech while /v1/infer is polled; per stream the
    delay from the end of speech to the decision, and the HTTP percentiles idle and under load."""
    from siftom.bench.robots import ServeBenchOptions, run_serve_bench

    if args.out is not None:
        prepare_output(args.out, args.force)

    res = run_serve_bench(ServeBenchOptions(streams=args.streams, instructions=args.instructions,
                                            http_rps=args.http_rps, url=args.url, token=args.token, seed=args.seed,
                                            in_process=args.in_process, burst=args.burst))
    data = res.to_json()
    if args.out is not None:
        from siftom.bench.speech import write_json

        write_json(data, args.out)
    if args.as_json:
        click.echo(json.dumps(data, indent=2))
        return
    m = res.machine
    burst = " (burst: speech ends at once)" if args.burst else ""
    click.echo(f"{args.streams} streams x {args.instructions} instructions{burst}, "
               f"/v1/infer at {args.http_rps:g}/s; "
               f"{m.cpus} CPUs ({m.processor}), load before {m.load_avg}, after {res.load_avg_after}")
    click.echo(f"decisions {res.answered}/{res.expected}; end of speech -> decision p50 {res.delay_p50_s} s, "
               f"p90 {res.delay_p90_s} s")
    click.echo(f"/v1/infer idle p50 {res.idle_infer_ms['p50']} ms p90 {res.idle_infer_ms['p90']} ms; under load "
               f"p50 {res.load_infer_ms['p50']} ms p90 {res.load_infer_ms['p90']} ms ({res.infer_errors} errors)")
    for st in res.streams:
        click.echo(f"  {st['session'][:8]}  delays {st['delays_s']}  closed {st['closed']}")
    if res.in_process is not None and res.in_process["p50_s"] and res.delay_p50_s:
        lp = res.in_process
        click.echo(f"in-process listener on the first recording: p50 {lp['p50_s']} s, p90 {lp['p90_s']} s; "
                   f"WebSocket / in-process p50 {res.delay_p50_s / lp['p50_s']:.2f}")
    click.echo("meets the floors (every decision, p90 <= 1 s, /v1/infer p90 <= 3x idle): "
               + ("yes" if res.meets() else "no"))


@click.command("hostile")
@click.option("--url", default=None, help="a running server (default: start siftom serve on loopback)")
@click.option("--token", default=None, help="the running server's token")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="also write the result as JSON here")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@force_option
def bench_hostile_cmd(url: str | None, token: str | None, out: Path | None, as_json: bool, force: bool) -> None:
    """Hostile inputs against a server while /healthz is polled: huge worlds and names (each a 4xx
    naming its limit within a second), streams trickling bytes into every slot, oversized stream
    lines and messages, rotating X-Forwarded-For headers, oversized ROS text and action lines;
    /healthz within 100 ms meanwhile. Against a --url server with a --token, the header cases
    throttle this machine's address there for a minute."""
    from siftom.bench.hostile import run_hostile_bench

    if out is not None:
        prepare_output(out, force)

    res = run_hostile_bench(url, token)
    if out is not None:
        from siftom.bench.speech import write_json

        write_json(res.to_json(), out)
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    m = res.machine
    click.echo(f"{m.cpus} CPUs ({m.processor}), load before {m.load_avg}")
    for r in res.rows:
        click.echo(f"  {r.input:32s} {r.status} in {r.seconds:.3f} s, /healthz max {r.healthz_max_ms} ms "
                   f"({r.healthz_n} polls): {r.detail[:90]}")
    click.echo("meets (each the answer it must get, in time; /healthz within 100 ms): "
               + ("yes" if res.meets else "no"))


def register(root: click.Group) -> None:
    """Add the speed benchmarks to the ``bench`` group."""
    from siftom.cli.bench import bench_group

    for cmd in (bench_inference_cmd, bench_planner_cmd, bench_latency_cmd, bench_robots_cmd, bench_hostile_cmd):
        bench_group.add_command(cmd)
