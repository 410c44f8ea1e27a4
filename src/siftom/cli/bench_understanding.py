"""``siftom bench understanding``: how often the robot understands what people say, per kind of
utterance and condition (docs/understanding.md)."""

from __future__ import annotations

import dataclasses
import json

import click

from siftom.cli.bench import _bar, _csv
from siftom.cli.outputs import force_option, prepare_output
from siftom.cli.records import pass_options

_CONDITIONS = ("text", "clean", "10dB", "5dB")


def _conditions(value: str) -> tuple[str, ...]:
    """``--conditions``: comma-separated, each one of text, clean, 10dB, 5dB (any case)."""
    by_lower = {c.lower(): c for c in _CONDITIONS}
    got = []
    for v in _csv(value):
        if v.lower() not in by_lower:
            raise click.BadParameter(f"unknown condition {v!r}; give a comma-separated list of "
                                     f"{', '.join(_CONDITIONS)}, e.g. --conditions text,clean", param_hint="--conditions")
        got.append(by_lower[v.lower()])
    if not got:
        raise click.BadParameter(f"no condition given; choose from {', '.join(_CONDITIONS)}", param_hint="--conditions")
    return tuple(dict.fromkeys(got))


@dataclasses.dataclass(frozen=True)
class UnderstandingBenchFlags:
    """The ``siftom bench understanding`` flags as one record."""

    set_name: str
    items_file: str | None
    world_seed: int | None
    worlds: int
    conditions: str
    kinds: str | None
    voices: str | None
    limit: int | None
    out: str | None
    seed: int
    as_json: bool
    from_files: tuple[str, ...]
    measure: str
    force: bool


@click.command("understanding")
@click.option("--set", "set_name", type=click.Choice(["dev", "heldout", "unseen", "blind"]), default="dev",
              show_default=True,
              help="the wordings: dev, heldout or unseen (generated from templates written apart, other worlds), "
                   "or blind (hand-written by someone who never ran the model: repairs, objects outside the "
                   "lexicon, counts beyond supply, modifiers, replies to a question)")
@click.option("--items", "items_file", type=click.Path(dir_okay=False), default=None,
              help="a JSON-lines file of hand-written items in the blind set's format instead of --set "
                   "(docs/understanding.md)")
@click.option("--world-seed", "world_seed", type=click.IntRange(min=0), default=None,
              help="the worlds' seed (default: 201 for dev, 202 for heldout, 203 for unseen)")
@click.option("--worlds", type=click.IntRange(min=1), default=6, show_default=True, help="worlds per domain")
@click.option("--conditions", default="text", show_default=True,
              help="comma-separated: text (the words), clean (spoken by TTS voices), 10dB and 5dB (in recorded "
                   "household noise at that SNR)")
@click.option("--kinds", default=None,
              help="comma-separated kinds to run (default: all), e.g. plain,correction,nonrequest")
@click.option("--voices", default=None,
              help="comma-separated TTS voices for the recorded conditions, rotating over the items "
                   "(default: every installed voice of flite-slt, flite-awb, espeak-en-us+klatt, hibari-heart)")
@click.option("--limit", type=click.IntRange(min=1), default=None,
              help="run only the first N items (kinds mixed; after --kinds)")
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="FILE.jsonl: one row per item and condition (what was heard and done, understood, answered "
                   "with nothing, acted on another object, nobody-asked acted on); FILE.summary.json (per kind "
                   "and condition, the gates, machine and version) and, for recorded conditions, FILE.audio/ "
                   "beside it")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="seed of the items' objects, counts and wordings and of the noise")
@click.option("--json", "as_json", is_flag=True, help="print the summary as JSON")
@click.option("--from", "from_files", multiple=True, type=click.Path(exists=True, dir_okay=False),
              help="run nothing: print a Markdown table per kind from FILE.summary.json files of earlier runs "
                   "(repeatable; a column per file and condition)")
@click.option("--measure", type=click.Choice(["understood", "nothing", "other_object", "acted_unasked",
                                             "asked_unasked"]), default="understood", show_default=True,
              help="with --from: the share understood, or the share of requests answered with nothing, carried "
                   "out on another object, nobody-asked acted on or asked back")
@force_option
@pass_options(UnderstandingBenchFlags)
def bench_understanding_cmd(args: UnderstandingBenchFlags) -> None:
    """How often the robot understands what people say: per kind of utterance and condition.

    Beside the share understood, per kind: requests answered with nothing (no action, no
    question), requests carried out on another object, and words nobody addressed to the robot
    acted on; the summary checks them against the benchmark's targets (gates). Progress goes to
    stderr; --out writes rows a user can re-plot.

    \b
    siftom bench understanding --set blind --out results/understanding/blind-text.jsonl
    siftom bench understanding --set blind --conditions 10dB,5dB --limit 40 --voices flite-slt,flite-awb
    siftom bench understanding --from A.summary.json --from B.summary.json --measure nothing
    """
    from rich.console import Console

    from siftom.bench.understanding import (
        BLIND,
        BLIND_KINDS,
        WORLD_SEEDS,
        gate_lines,
        items_of,
        markdown,
        run_benchmark,
        table,
    )
    from siftom.bench.understanding_report import calibration_lines

    if args.from_files:
        summaries = []
        for f in args.from_files:
            try:
                with open(f, encoding="utf-8") as fh:
                    got = json.load(fh)
            except (OSError, ValueError):
                got = None
            if not (isinstance(got, dict) and isinstance(got.get("by_kind"), dict)
                    and isinstance(got.get("overall"), dict)):
                raise click.BadParameter(f"{f} is not a summary of bench understanding (FILE.summary.json); "
                                         "give the .summary.json an --out run wrote", param_hint="--from")
            summaries.append((str(got.get("set", f)), got))
        click.echo(markdown(summaries, args.measure))
        for _, got in summaries:
            for line in gate_lines(got):
                click.echo(f"{got.get('set', '?')}: {line}")
        return
    conds = _conditions(args.conditions)
    if args.out is not None:
        prepare_output(args.out, args.force)
    blind = args.set_name == BLIND or args.items_file is not None
    ws = None if blind else (WORLD_SEEDS[args.set_name] if args.world_seed is None else args.world_seed)
    items = items_of(BLIND if args.items_file is not None else args.set_name, ws, args.worlds, args.seed,
                     args.items_file)
    want = _csv(args.kinds)
    if want:
        bad = [k for k in want if k not in BLIND_KINDS]
        if bad:
            raise click.BadParameter(f"unknown kind {bad[0]!r}; kinds: {', '.join(BLIND_KINDS)}", param_hint="--kinds")
        items = [i for i in items if i.kind in want]
    items = items[:args.limit]
    if not items:
        raise click.BadParameter(f"no item of kind(s) {', '.join(want)} in this set", param_hint="--kinds")
    named = BLIND if args.items_file is None and blind else (args.items_file or args.set_name)
    meta: dict[str, object] = {"set": named, "world_seed": ws,
                               "worlds_per_domain": None if blind else args.worlds, "seed": args.seed,
                               "limit": args.limit, "kinds": list(want) or None}
    with _bar("understanding", not args.as_json) as bar:
        run = run_benchmark(items, conds, seed=args.seed, out=args.out, meta=meta, progress=bar,
                            voices=_csv(args.voices) or None)
    if args.as_json:
        click.echo(json.dumps(run.summary, indent=2))
        return
    Console().print(table(run))
    for line in gate_lines(run.summary) + calibration_lines(run.summary):
        click.echo(line)
    click.echo(f"{len(items)} items x {len(conds)} conditions in {run.seconds:.0f} s"
               + (f"; wrote {', '.join(run.files)}" if run.files else ""))


def register(root: click.Group) -> None:
    """Add ``understanding`` to the ``bench`` group."""
    from siftom.cli.bench import bench_group

    bench_group.add_command(bench_understanding_cmd)
