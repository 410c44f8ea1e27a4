"""``siftom simulate``: L_single, L_team and speedup of a robot command in a scenario;
``siftom simulate-trial`` and ``siftom bench trials``: whole trials of several requests."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import click

from siftom.cli.outputs import force_option, prepare_output
from siftom.cli.records import pass_options


@click.command("simulate")
@click.argument("scenario_id")
@click.option("--command", "command", required=True,
              help='Robot command, e.g. "deliver(fork,3)" or "fetch(cereal)".')
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def simulate_cmd(scenario_id: str, command: str, as_json: bool) -> None:
    """Simulate the human alone and with the robot executing COMMAND; print the speedup."""
    from siftom.agents.team import simulate_scenario
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    res = simulate_scenario(sc, sc.parse_command(command))
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    click.echo(f"{sc.id}: goal {sc.goal.describe()}; robot command {res.command}")
    click.echo(f"  L_single = {res.l_single:g} steps (human alone)")
    click.echo(f"  L_team   = {res.l_team:g} steps (observed {res.prefix:g} + max(human {res.human_steps:g}, "
               f"robot {res.robot_steps:g}) + remedy {res.remedy_steps:g})")
    click.echo(f"  speedup  = L_single / L_team - 1 = {res.speedup:+.3f}"
               f"   (useful objects {res.useful}, wrong {res.wrong})")


def _rule_option(f: Any) -> Any:
    return click.option("--rule", "rule", default=None,
                        help="decision rule: teammate, expected-benefit, ask-or-act, map (default: the setting infer.decide)")(f)


def _ask_for_option(f: Any) -> Any:
    return click.option("--ask-for", default="plan", show_default=True,
                        help="what the person asks for: plan (the robot's part of the best joint plan), "
                             "unstarted (any class not yet started) or any (any still needed); several, "
                             "comma-separated, for bench trials")(f)


def _channel_option(f: Any) -> Any:
    f = click.option("--p-err", "p_err", type=click.FloatRange(0.0, 1.0), default=0.3, show_default=True,
                     help="noisy channel: probability that the best hypothesis names a near class")(f)
    return click.option("--channel", default="oracle", show_default=True,
                        help="what the robot hears: oracle (a sampled phrasing, exactly) or noisy (a "
                             "phonetic confusion N-best); several, comma-separated, for bench trials")(f)


@click.command("simulate-trial")
@click.argument("scenario_id")
@_rule_option
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="seeds the request points and the phrasings")
@click.option("--max-requests", type=click.IntRange(min=0), default=3, show_default=True,
              help="the most requests the person makes")
@_channel_option
@_ask_for_option
@click.option("--json", "as_json", is_flag=True, help="Print JSON (metrics, requests, events).")
def simulate_trial_cmd(scenario_id: str, rule: str | None, seed: int, max_requests: int, channel: str,
                       p_err: float, ask_for: str, as_json: bool) -> None:
    """Simulate a whole trial: the person works towards the goal and asks the robot for items;
    print it step by step and the trial's speedup (docs/team-simulation.md, "Whole trials")."""
    from siftom.agents.trial import simulate_trial
    from siftom.bench.wholetrial import speaker_for
    from siftom.observer import Observer
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    res = simulate_trial(sc, Observer(), seed=seed, rule=rule, max_requests=max_requests,
                         speak=speaker_for(channel, sc.world, p_err), ask_for=ask_for)
    if as_json:
        click.echo(json.dumps({"channel": channel, "ask_for": ask_for, **res.to_json()}, indent=2))
        return
    click.echo(f"{sc.id}: goal {sc.goal.describe()} ({sc.goal.name}); rule {res.rule}; seed {seed}; "
               f"channel {channel}")
    for e in res.events:
        span = f"{e.start:6.1f}-{e.end:6.1f}" if e.end > e.start else f"{e.start:6.1f}       "
        click.echo(f"  {span}  {e.who:<8} {e.text}")
    click.echo(f"  L_single = {res.l_single:g} steps (the person alone)")
    click.echo(f"  L_team   = {res.l_team:g} steps (with the robot; remedy {res.remedy_steps:g})")
    click.echo(f"  speedup  = L_single / L_team - 1 = {res.speedup:+.3f}")
    click.echo(f"  requests {res.n_requests}: acted {res.acted}, wrong fetches {res.wrong_fetches}, "
               f"questions {res.questions}, refusals {res.refusals}")


@dataclasses.dataclass(frozen=True)
class TrialsBenchFlags:
    """The ``siftom bench trials`` flags as one record."""

    domain: str
    seeds: int
    seed_start: int
    rules: str
    max_requests: int
    channel: str
    p_err: float
    ask_for: str
    scenarios: tuple[str, ...]
    out: str | None
    force: bool
    as_json: bool
    no_progress: bool


@click.command("trials")
@click.option("--domain", default="kitchen-v0", show_default=True, help="kitchen-v0 | household-table-v0")
@click.option("--seeds", type=click.IntRange(min=1), default=5, show_default=True, help="seeds per scenario")
@click.option("--seed-start", type=click.IntRange(min=0), default=0, show_default=True,
              help="first seed (seeds SEED_START .. SEED_START + SEEDS - 1)")
@click.option("--rules", default="teammate", show_default=True,
              help="comma-separated decision rules: teammate (the product's), expected-benefit, ask-or-act, map")
@click.option("--max-requests", type=click.IntRange(min=0), default=3, show_default=True,
              help="the most requests per trial")
@_channel_option
@_ask_for_option
@click.option("--scenario", "scenarios", multiple=True, help="only these scenario ids (default: the domain's registered ones)")
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="write one JSON line per trial here (to re-plot; its folder is created)")
@force_option
@click.option("--json", "as_json", is_flag=True, help="print the per-rule summary as JSON")
@click.option("--no-progress", is_flag=True, help="no progress bar")
@pass_options(TrialsBenchFlags)
def bench_trials_cmd(args: TrialsBenchFlags) -> None:
    """Whole trials over a domain's scenarios x seeds x rules: mean speedup, wrong fetches,
    questions and refusals per trial, per rule (docs/team-simulation.md, "Whole trials")."""
    import contextlib

    from siftom.bench.wholetrial import markdown, run_trials, summarise
    from siftom.cli.bench import _bar, _csv
    from siftom.observer import Observer

    rule_list, channels = _csv(args.rules), _csv(args.channel)
    out_path = prepare_output(args.out, args.force) if args.out else None
    rows = []
    with contextlib.ExitStack() as stack:
        fh = stack.enter_context(out_path.open("w", encoding="utf-8")) if out_path else None
        bar = stack.enter_context(_bar(f"trials {args.domain}", enabled=not args.no_progress))
        for row in run_trials(args.domain, range(args.seed_start, args.seed_start + args.seeds), rule_list, Observer(),
                              channels=channels, max_requests=args.max_requests, p_err=args.p_err,
                              scenarios=args.scenarios or None, ask_for=_csv(args.ask_for), progress=bar):
            rows.append(row)
            if fh is not None:
                fh.write(json.dumps(row) + "\n")
                fh.flush()
    summary = summarise(rows)
    if args.as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    click.echo(markdown(summary))
    if args.out:
        click.echo(f"\n{len(rows)} trials; wrote {args.out}")


def register(root: click.Group) -> None:
    from siftom.cli.bench import bench_group

    root.add_command(simulate_cmd)
    root.add_command(simulate_trial_cmd)
    bench_group.add_command(bench_trials_cmd)
