"""Benchmark subcommands: ``dataset build``, ``dataset check``, ``eval``, ``report``, ``sweep`` and
the ``bench`` group (``bench understanding``: :mod:`siftom.cli.bench_understanding`)."""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext

import click

from siftom.backends.cli_options import flags_given, llm_config, llm_options
from siftom.cli.records import pass_options
from siftom.errors import DatasetError
from siftom.speech.asr import DEFAULT_NBEST
from siftom.speech.asr.base import ENGINES
from siftom.speech.cli_options import whisper_model_option


def _csv(value: str | None) -> tuple[str, ...]:
    if value is None:
        return ()
    return tuple(v.strip() for v in value.split(",") if v.strip())


def _snrs(value: str) -> tuple[float, ...]:
    if value.strip().lower() in ("", "none"):
        return ()
    from siftom.cli.audio_out import SNR_MAX_DB, SNR_MIN_DB

    try:
        snrs = tuple(float(v) for v in _csv(value))
    except ValueError:
        raise DatasetError(f"--snr must be comma-separated numbers of dB, e.g. 20,10,5; got {value!r}") from None
    far = [f"{x:g}" for x in snrs if not SNR_MIN_DB <= x <= SNR_MAX_DB]
    if far:
        raise DatasetError(f"--snr {', '.join(far)}: give SNRs from {SNR_MIN_DB:g} to {SNR_MAX_DB:g} dB, "
                           "e.g. 20,10,5")
    return snrs


def _distances(value: str | None) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in _csv(value))
    except ValueError:
        raise DatasetError(f"--distances must be comma-separated metres, e.g. 1,3; got {value!r}") from None


def _default_workers() -> int:
    return max(1, min(4, os.cpu_count() or 1))


def _backend_options(f: Callable[..., None]) -> Callable[..., None]:
    """--backend and --ray-address (bench/backends.py)."""
    f = click.option("--ray-address", default=None,
                     help="with --backend ray: 'auto' or HOST:PORT of a running cluster (default: start a local Ray)")(f)
    return click.option("--backend", type=click.Choice(["local", "ray"]), default="local", show_default=True,
                        help="where the work runs: local processes, or Ray (pip install \"siftom[ray]\")")(f)


@contextmanager
def _backend(name: str, workers: int | None, address: str | None) -> Iterator[object]:
    """The backend for a command; a signal-stopped run exits 128 + signal with how to resume."""
    import signal

    from siftom.bench.backends import make_backend
    from siftom.bench.runlock import interrupting_signal, stop_on_signals

    try:
        with stop_on_signals():
            be = make_backend(name, workers or (None if name == "ray" else _default_workers()), address)
            with stop_on_signals():  # again: ray.init replaces the SIGTERM handler
                try:
                    yield be
                finally:
                    be.shutdown()
    except KeyboardInterrupt as exc:
        signum = interrupting_signal(exc)
        err = click.ClickException(f"stopped by {signal.Signals(signum).name}; what was finished is saved: "
                                   "run the same command again to resume")
        err.exit_code = 128 + signum  # type: ignore[misc]  # click reads it per instance
        raise err from None


@contextmanager
def _bar(label: str, enabled: bool = True) -> Iterator[Callable[[int, int], None]]:
    """A rich progress bar on stderr, updated with (done, total)."""
    if not enabled:
        yield lambda done, total: None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TimeRemainingColumn(), console=Console(stderr=True), transient=False) as p:
        task = p.add_task(label, total=None)

        def update(done: int, total: int) -> None:
            p.update(task, completed=done, total=total)

        yield update


@click.group("dataset")
def dataset_group() -> None:
    """Build and check UnclearInstruct-style benchmark datasets."""


@dataclasses.dataclass(frozen=True)
class BuildFlags:
    """The ``siftom dataset build`` flags as one record."""

    domain: str
    out: str
    scenarios: int
    speakers: int
    voices: str | None
    noise_dir: str | None
    noises: str | None
    snr: str
    seed: int
    world_seed: int | None
    room: float | None
    rooms: str | None
    distances: str | None
    phrasings: str | None
    workers: int | None
    backend: str
    ray_address: str | None
    as_json: bool


@dataset_group.command("build")
@click.option("--domain", default="household-table-v0", show_default=True, help="household-table-v0 | kitchen-v0")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, help="dataset folder to write")
@click.option("--scenarios", type=int, default=26, show_default=True,
              help="scenarios (registered first, then generated; with --world-seed: generated worlds)")
@click.option("--speakers", type=int, default=5, show_default=True, help="speakers per scenario")
@click.option("--voices", default=None, help="comma-separated voices (siftom voices); default: 2 flite + 3 espeak Klatt")
@click.option("--noise-dir", type=click.Path(file_okay=False), default=None,
              help="folder of noise WAVs named CATEGORY_NN.wav, or 'recorded' for the real "
                   "household recordings shipped with siftom; default: synthetic noise")
@click.option("--noises", default=None, help="noise types: categories of --noise-dir or babble,pink,hum,white,brown")
@click.option("--snr", "snr", default="20,10,5", show_default=True, help="one noisy condition per SNR (dB); 'none' = clean only")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="seed for phrasings, speakers and noise")
@click.option("--world-seed", "world_seed", type=click.IntRange(min=0), default=None,
              help="draw the scenarios from this seed (--scenarios N = N generated worlds, no registered "
                   "one) instead of the registered scenarios every constant was tuned on; default: registered")
@click.option("--room", type=float, default=None,
              help="reverberation time RT60 in seconds: the speaker is heard across a reverberant room "
                   "(a seeded synthetic impulse response per clip) before the noise")
@click.option("--rooms", default=None,
              help="simulated rooms kitchen,living,open (pip install \"siftom[rooms]\"): each scenario x "
                   "speaker is heard in one room at one of --distances (image-source responses); not with --room")
@click.option("--distances", default=None,
              help="talker-to-microphone distances in metres for --rooms, e.g. 1,3 (0.5-6, fitting every room)")
@click.option("--phrasings", "phrasings", default=None,
              help="carrier file: UTF-8, one carrier per line with {np}, '#' comments; or a shipped set "
                   "(free-v0, free-heldout-v0). Default: siftom's phrasing grammar")
@click.option("--workers", type=int, default=None, help="processes or Ray CPUs (default: number of CPUs, at most 4)")
@_backend_options
@click.option("--json", "as_json", is_flag=True, help="print a JSON summary")
@pass_options(BuildFlags)
def build_cmd(args: BuildFlags) -> None:
    """Build a dataset: each speaker asks for the robot's part of each scenario, clean and in noise."""
    from siftom.bench.dataset import build_dataset
    from siftom.people.stimuli import DEFAULT_VOICES, BuildOptions

    opts = BuildOptions(domain=args.domain, scenarios=args.scenarios, speakers=args.speakers,
                        voices=_csv(args.voices) or DEFAULT_VOICES, noise_dir=args.noise_dir,
                        noises=_csv(args.noises), snrs=_snrs(args.snr), seed=args.seed, phrasings=args.phrasings,
                        room=args.room, world_seed=args.world_seed, rooms=_csv(args.rooms),
                        distances=_distances(args.distances))
    from siftom.cli.audio_out import FOLDER_FIX, writing_audio

    t0 = time.perf_counter()
    with _backend(args.backend, args.workers, args.ray_address) as be, _bar("building", not args.as_json) as bar, \
            writing_audio(args.out, "the dataset into", fix=FOLDER_FIX):
        ds = build_dataset(opts, args.out, progress=bar, backend=be)
    secs = time.perf_counter() - t0
    if args.as_json:
        click.echo(json.dumps({"out": str(ds.root), "stimuli": len(ds.stimuli), "seconds": round(secs, 1)}))
    else:
        click.echo(f"wrote {len(ds.stimuli)} stimuli to {ds.root} in {secs:.0f} s "
                   f"(manifest.jsonl, audio/, README.md)")


@dataset_group.command("check")
@click.argument("folder", type=click.Path(file_okay=False))
def check_cmd(folder: str) -> None:
    """Check a dataset folder (manifest keys, audio files, scenarios) without evaluating it."""
    from collections import Counter

    from siftom.people.stimuli import load_dataset, scenario_for

    ds = load_dataset(folder)
    for s in ds.stimuli:
        scenario_for(s)
    conds = Counter(s.condition.split("@")[0] for s in ds.stimuli)
    click.echo(f"ok: {len(ds.stimuli)} stimuli, {len({s.scenario for s in ds.stimuli})} scenarios, "
               f"{len({s.speaker for s in ds.stimuli})} speakers; " + ", ".join(f"{k} {v}" for k, v in sorted(conds.items())))


@dataclasses.dataclass(frozen=True)
class EvalFlags:
    """The ``siftom eval`` flags as one record."""

    dataset: str
    out: str
    models: str | None
    engine: str
    nbest: int
    workers: int | None
    backend: str
    ray_address: str | None
    seed: int
    overwrite: bool
    as_json: bool
    human: str | None
    llm_backend: str | None
    llm_base_url: str | None
    llm_model: str | None


@click.command("eval")
@whisper_model_option
@click.option("--dataset", "dataset", type=click.Path(file_okay=False), required=True, help="dataset folder")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, help="results folder (resumes if it exists)")
@click.option("--models", default=None, help="comma-separated; default: literal-asr,speech-only,action-only,siftom "
              "(the product's default: the acoustic likelihood with the whisper extra, else phonetic),"
              "siftom-phonetic,siftom-oracle-text,siftom-eb,siftom-ask (decision rules on the acoustic likelihood, "
              "docs/decisions.md), plus siftom-llm,llm-end-to-end,llm-ablated-siftom when an LLM is "
              "configured (--llm-* flags or SIFTOM_LLM_*, docs/llm.md); on request: siftom-acoustic "
              "(= siftom with Whisper), speech-only-acoustic, siftom-phonetic-eb, siftom-phonetic-ask "
              "(the rules on the phonetic likelihood)")
@click.option("--engine", default="pocketsphinx-vocab", show_default=True,
              help=f"ASR engine: {ENGINES.help_line('')}")
@click.option("--nbest", type=int, default=DEFAULT_NBEST, show_default=True, help="ASR hypotheses given to the models")
@click.option("--workers", type=int, default=None, help="processes or Ray CPUs (default: number of CPUs, at most 4)")
@_backend_options
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="bootstrap seed")
@click.option("--overwrite", is_flag=True, help="start over when --out holds another run")
@click.option("--json", "as_json", is_flag=True, help="print summary.json")
@click.option("--human", "human", type=click.Path(file_okay=False), default=None,
              help="an annotation folder (siftom annotate --out): its answers join the report as the model 'human'")
@llm_options
@pass_options(EvalFlags)
def eval_cmd(args: EvalFlags) -> None:
    """Transcribe every stimulus once, run every model, write results, summary, report and figures."""
    from siftom.backends.config import llm_configured
    from siftom.bench.evaluate import EvalOptions, evaluate
    from siftom.bench.models import default_models, eval_model
    from siftom.bench.report import main_table, participants_table, write_report

    configured = llm_configured() or flags_given(args.llm_backend, args.llm_base_url, args.llm_model)
    default = default_models(llm=configured)
    if not configured and not args.as_json and not args.models:
        click.echo("note: no LLM configured, so the LLM models are skipped (set SIFTOM_LLM_BASE_URL and "
                   "SIFTOM_LLM_MODEL, SIFTOM_LLM_BACKEND=llama, or the --llm-* flags; docs/llm.md)", err=True)
    chosen = _csv(args.models) or default
    llm = (llm_config(args.llm_backend, args.llm_base_url, args.llm_model)
           if any(m in default_models(llm=True) and eval_model(m).needs_llm for m in chosen) else None)
    opts = EvalOptions(models=chosen, engine=args.engine, nbest=args.nbest, seed=args.seed, llm=llm)
    from siftom.bench.backends import check_backend_args
    from siftom.bench.runlock import RunLock

    check_backend_args(args.backend, args.ray_address)
    with RunLock(args.out), _backend(args.backend, args.workers, args.ray_address) as be:
        with _bar("evaluating", not args.as_json) as bar:
            run = evaluate(args.dataset, args.out, opts, overwrite=args.overwrite, progress=bar, backend=be)
        if args.human is not None:
            from siftom.bench.human import score_answers

            score_answers(args.human, args.out, args.dataset)
        summary = write_report(args.out)
    if args.as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    click.echo(main_table(summary))
    if summary.get("participants"):  # collected recordings: each participant's rows too
        click.echo("\nby participant:\n" + participants_table(summary["participants"]))
    click.echo(f"\n{run.evaluated} stimuli evaluated, {run.resumed} resumed, in {run.seconds:.0f} s; "
               f"wrote {args.out}/results.jsonl, summary.json, report.md and figures")


@click.command("report")
@click.argument("results", type=click.Path(file_okay=False))
@click.option("--seed", type=click.IntRange(min=0), default=None, help="bootstrap seed (default: the run's)")
@click.option("--json", "as_json", is_flag=True, help="print summary.json")
@click.option("--human", "human", type=click.Path(file_okay=False), default=None,
              help="an annotation folder (siftom annotate --out): score its answers as the model 'human'")
@click.option("--ratings", "ratings", type=click.Path(), multiple=True,
              help="a ratings.jsonl of 'siftom serve --data-dir DIR' (or DIR): add people's ratings per model")
@click.option("--no-figures", is_flag=True, help="write summary.json and report.md only (faster)")
def report_cmd(results: str, seed: int | None, as_json: bool, human: str | None, ratings: tuple[str, ...],
               no_figures: bool) -> None:
    """Re-render summary.json, report.md and the figures from RESULTS/results.jsonl
    (and RESULTS/human.jsonl, RESULTS/ratings.jsonl when present)."""
    from siftom.bench.report import main_table, participants_table, write_report
    from siftom.bench.runlock import RunLock

    with RunLock(results) if os.path.isdir(results) else nullcontext():
        if human is not None:
            from siftom.bench.human import score_answers

            score_answers(human, results)
        for r in ratings:
            from siftom.people.ratings import import_ratings

            import_ratings(r, results)
        summary = write_report(results, seed=seed, figures=not no_figures)
    click.echo(json.dumps(summary, indent=2) if as_json else main_table(summary))
    if summary.get("participants") and not as_json:
        click.echo("\nby participant:\n" + participants_table(summary["participants"]))


@click.command("sweep")
@click.argument("config", type=click.Path(dir_okay=False))
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, help="sweep folder (resumes if it exists)")
@click.option("--workers", type=int, default=None, help="processes or Ray CPUs (default: number of CPUs, at most 4)")
@_backend_options
@click.option("--json", "as_json", is_flag=True, help="print sweep.json")
def sweep_cmd(config: str, out: str, workers: int | None, backend: str, ray_address: str | None, as_json: bool) -> None:
    """Run the cross product of a sweep CONFIG.toml (datasets x evaluations); write table.md and sweep.png."""
    from siftom.bench.sweep import load_config, markdown_table, plan, run_sweep, table_rows

    n = len(plan(load_config(config), out))

    def show(i: int, total: int, cell: object) -> None:
        if not as_json and i < total:
            click.echo(f"cell {i + 1}/{total}: {getattr(cell, 'values', '')}", err=True)

    with _backend(backend, workers, ray_address) as be:
        result = run_sweep(config, out, be, progress=show)
    if as_json:
        click.echo(json.dumps(result.to_json(), indent=2, default=list))
        return
    click.echo(markdown_table(table_rows(result)))
    click.echo(f"\n{n} cells; wrote {out}/sweep.json, table.md, table.csv and sweep.png")


@click.group("bench")
def bench_group() -> None:
    """Benchmarks (speed and accuracy); --json for machines."""


def register(root: click.Group) -> None:
    """Add ``dataset``, ``eval``, ``report``, ``sweep`` and the ``bench`` group (which the other
    areas fill: ``siftom.cli.bench.bench_group``) to the root command."""
    root.add_command(bench_group)
    root.add_command(dataset_group)
    root.add_command(eval_cmd)
    root.add_command(report_cmd)
    root.add_command(sweep_cmd)
