"""Benchmark subcommands: ``dataset build``, ``dataset check``, ``eval``, ``report``."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import click

from siftom.errors import DatasetError


def _csv(value: str | None) -> tuple[str, ...]:
    if value is None:
        return ()
    return tuple(v.strip() for v in value.split(",") if v.strip())


def _snrs(value: str) -> tuple[float, ...]:
    if value.strip().lower() in ("", "none"):
        return ()
    try:
        return tuple(float(v) for v in _csv(value))
    except ValueError:
        raise DatasetError(f"--snr must be comma-separated numbers of dB, e.g. 20,10,5; got {value!r}") from None


def _default_workers() -> int:
    return max(1, min(4, os.cpu_count() or 1))


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


@dataset_group.command("build")
@click.option("--domain", default="household-table-v0", show_default=True, help="household-table-v0 | kitchen-v0")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, help="dataset folder to write")
@click.option("--scenarios", type=int, default=26, show_default=True, help="scenarios (registered first, then generated)")
@click.option("--speakers", type=int, default=5, show_default=True, help="speakers per scenario")
@click.option("--voices", default=None, help="comma-separated voices (siftom voices); default: 2 flite + 3 espeak Klatt")
@click.option("--noise-dir", type=click.Path(file_okay=False), default=None,
              help="folder of noise WAVs named CATEGORY_NN.wav; default: synthetic noise")
@click.option("--noises", default=None, help="noise types: categories of --noise-dir or babble,pink,hum,white,brown")
@click.option("--snr", "snr", default="20,10,5", show_default=True, help="one noisy condition per SNR (dB); 'none' = clean only")
@click.option("--seed", type=int, default=0, show_default=True, help="seed for phrasings, speakers and noise")
@click.option("--phrasings", "phrasings", default=None,
              help="carrier file: UTF-8, one carrier per line with {np}, '#' comments; or a shipped set "
                   "(free-v0, free-heldout-v0). Default: siftom's phrasing grammar")
@click.option("--workers", type=int, default=None, help="processes (default: number of CPUs, at most 4)")
@click.option("--json", "as_json", is_flag=True, help="print a JSON summary")
def build_cmd(domain: str, out: str, scenarios: int, speakers: int, voices: str | None, noise_dir: str | None,
              noises: str | None, snr: str, seed: int, phrasings: str | None, workers: int | None,
              as_json: bool) -> None:
    """Build a dataset: each speaker asks for the robot's part of each scenario, clean and in noise."""
    from siftom.bench.dataset import DEFAULT_VOICES, BuildOptions, build_dataset

    opts = BuildOptions(domain=domain, scenarios=scenarios, speakers=speakers,
                        voices=_csv(voices) or DEFAULT_VOICES, noise_dir=noise_dir, noises=_csv(noises),
                        snrs=_snrs(snr), seed=seed, phrasings=phrasings)
    t0 = time.perf_counter()
    with _bar("building", not as_json) as bar:
        ds = build_dataset(opts, out, workers=workers or _default_workers(), progress=bar)
    secs = time.perf_counter() - t0
    if as_json:
        click.echo(json.dumps({"out": str(ds.root), "stimuli": len(ds.stimuli), "seconds": round(secs, 1)}))
    else:
        click.echo(f"wrote {len(ds.stimuli)} stimuli to {ds.root} in {secs:.0f} s "
                   f"(manifest.jsonl, audio/, README.md)")


@dataset_group.command("check")
@click.argument("folder", type=click.Path(file_okay=False))
def check_cmd(folder: str) -> None:
    """Check a dataset folder (manifest keys, audio files, scenarios) without evaluating it."""
    from collections import Counter

    from siftom.bench.dataset import load_dataset, scenario_for

    ds = load_dataset(folder)
    for s in ds.stimuli:
        scenario_for(s)
    conds = Counter(s.condition.split("@")[0] for s in ds.stimuli)
    click.echo(f"ok: {len(ds.stimuli)} stimuli, {len({s.scenario for s in ds.stimuli})} scenarios, "
               f"{len({s.speaker for s in ds.stimuli})} speakers; " + ", ".join(f"{k} {v}" for k, v in sorted(conds.items())))


@click.command("eval")
@click.option("--dataset", "dataset", type=click.Path(file_okay=False), required=True, help="dataset folder")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, help="results folder (resumes if it exists)")
@click.option("--models", default=None, help="comma-separated; default: literal-asr,speech-only,action-only,siftom,"
              "siftom-oracle-text, plus llm-end-to-end,llm-ablated-siftom when an LLM is configured "
              "(SIFTOM_LLM_BASE_URL + SIFTOM_LLM_MODEL, or SIFTOM_LLM=llama)")
@click.option("--engine", default="pocketsphinx-vocab", show_default=True, help="pocketsphinx-vocab | pocketsphinx-open | pocketsphinx | whisper")
@click.option("--nbest", type=int, default=5, show_default=True, help="ASR hypotheses given to the models")
@click.option("--workers", type=int, default=None, help="processes (default: number of CPUs, at most 4)")
@click.option("--seed", type=int, default=0, show_default=True, help="bootstrap seed")
@click.option("--overwrite", is_flag=True, help="start over when --out holds another run")
@click.option("--json", "as_json", is_flag=True, help="print summary.json")
def eval_cmd(dataset: str, out: str, models: str | None, engine: str, nbest: int, workers: int | None,
             seed: int, overwrite: bool, as_json: bool) -> None:
    """Transcribe every stimulus once, run every model, write results, summary, report and figures."""
    from siftom.bench.evaluate import MODELS, OPTIONAL_MODELS, EvalOptions, evaluate
    from siftom.bench.llm_baselines import configured_backend
    from siftom.bench.report import main_table, write_report

    default = MODELS + (OPTIONAL_MODELS if configured_backend() else ())
    if configured_backend() is None and not as_json and not models:
        click.echo("note: no LLM configured, so the LLM baselines are skipped (set SIFTOM_LLM_BASE_URL and "
                   "SIFTOM_LLM_MODEL, or SIFTOM_LLM=llama)", err=True)
    opts = EvalOptions(models=_csv(models) or default, engine=engine, nbest=nbest, seed=seed)
    with _bar("evaluating", not as_json) as bar:
        run = evaluate(dataset, out, opts, workers=workers or _default_workers(), overwrite=overwrite, progress=bar)
    summary = write_report(out)
    if as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    click.echo(main_table(summary))
    click.echo(f"\n{run.evaluated} stimuli evaluated, {run.resumed} resumed, in {run.seconds:.0f} s; "
               f"wrote {out}/results.jsonl, summary.json, report.md and figures")


@click.command("report")
@click.argument("results", type=click.Path(file_okay=False))
@click.option("--seed", type=int, default=None, help="bootstrap seed (default: the run's)")
@click.option("--json", "as_json", is_flag=True, help="print summary.json")
def report_cmd(results: str, seed: int | None, as_json: bool) -> None:
    """Re-render summary.json, report.md and the figures from RESULTS/results.jsonl."""
    from siftom.bench.report import main_table, write_report

    summary = write_report(results, seed=seed)
    click.echo(json.dumps(summary, indent=2) if as_json else main_table(summary))


def register(root: click.Group) -> None:
    """Add ``dataset``, ``eval`` and ``report`` to the root command."""
    root.add_command(dataset_group)
    root.add_command(eval_cmd)
    root.add_command(report_cmd)
