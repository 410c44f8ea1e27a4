"""Evaluate models on a dataset: transcribe each stimulus once, run every model, simulate the team.

Models (names as in ``summary.json``):

* ``literal-asr``: the 1-best transcript read by a classic command parser (``literal.py``);
* ``speech-only``: SIFToM's instruction likelihood alone over the N-best list, uniform prior;
* ``action-only``: SIFToM's goal inference from the observed actions alone (no speech);
* ``siftom``: the product's default path, actions + the acoustic likelihood (N-best and
  Whisper's score of the audio) when the whisper extra is installed, else the N-best phonetic one;
* ``siftom-phonetic``: the full model, actions + the N-best phonetic likelihood;
* ``siftom-oracle-text``: the full model given the reference transcript (an upper bound);
* ``siftom-llm``: the full model with the paper's LLM instruction likelihood (``likelihood/llm.py``);
  with ``llm-end-to-end`` and ``llm-ablated-siftom`` it runs only when an LLM is configured;
* on request, ``siftom-acoustic`` (the ``siftom`` row with Whisper) and ``speech-only-acoustic``: the
  audio itself (bench/acoustic_models.py).

Per stimulus the chosen command is scored against the gold one (object class and count exact;
class only for ``fetch`` domains), called a helpful error when wrong but its class is part of
the goal, and simulated (agents/team.py) for L_single, L_team, remedy steps and speedup.

Operation: work is grouped by scenario so that a worker process reuses the scenario's planner
tables and team simulations; each finished stimulus is appended to ``results.jsonl`` at once,
so an interrupted run resumes where it stopped. Transcripts and team simulations are cached in
the results folder (``transcripts.jsonl``, ``team_cache.jsonl``).
"""

from __future__ import annotations

import json
import os
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from siftom.bench.engines import engine as _engine
from siftom.bench.models import (  # re-exported: what to evaluate
    EvalOptions,
)
from siftom.bench.results_io import (
    RESULTS,
    TIMINGS,
    AtomicAppender,
    Provenance,
    check_unique,
    load_results,
    provenance,
    provenance_mismatch,
    read_jsonl,
    rewrite,
)
from siftom.bench.runlock import RunLock, stop_on_signals
from siftom.bench.trials import (
    _eval_stimuli,
    _Finished,
    _run_task,
    _Task,
    dataset_vocabulary,
    scenario_key,
)
from siftom.errors import DatasetError
from siftom.people.stimuli import Dataset, Stimulus, load_dataset
from siftom.speech.asr.base import is_scene_engine

# run only when a language model is configured (siftom.bench.llm_baselines)
__all__ = ["RESULTS", "RUN", "TEAM_CACHE", "TRANSCRIPTS", "EvalOptions", "EvalRun", "evaluate", "load_results"]

RUN = "run.json"
TRANSCRIPTS = "transcripts.jsonl"
TEAM_CACHE = "team_cache.jsonl"


@dataclass
class EvalRun:
    """What an evaluation did: rows in manifest order, how many were new, timings."""

    out: Path
    rows: list[dict[str, Any]]
    resumed: int
    evaluated: int
    seconds: float
    counters: dict[str, float] = field(default_factory=dict)


# -- files ---------------------------------------------------------------------------------

_read_jsonl = read_jsonl  # the name older code imports


def evaluate(
    dataset: str | Path | Dataset,
    out: str | Path,
    options: EvalOptions | None = None,
    workers: int = 1,
    overwrite: bool = False,
    progress: Callable[[int, int], None] | None = None,
    backend: Any = None,
) -> EvalRun:
    """Evaluate every model on every stimulus not yet in ``out/results.jsonl``.

    The run owns ``out`` while it works (a second run on it is refused, see bench/runlock.py);
    SIGINT and SIGTERM stop it and its workers, raising RunInterrupted, and leave a folder that
    resumes. ``results.jsonl`` ends in manifest order and without timings (``timings.jsonl``),
    so it is the same, byte for byte, on every backend.

    Args:
        dataset: a dataset folder (or a loaded Dataset).
        out: the results folder (created).
        options: models, engine, N-best size, likelihood, bootstrap seed.
        workers: processes (1 = in this process), or Ray CPUs.
        overwrite: start over when ``out`` holds a run with other settings or data.
        progress: called with (stimuli done, total) after each stimulus.
        backend: ``"local"`` (default), ``"ray"`` or a backend object (bench/backends.py);
            one given as an object is left running for the caller.

    Raises:
        DatasetError: malformed dataset, or ``out`` holds another run (and not ``overwrite``).
        RunLockedError: another live process is writing into ``out``.
    """
    from siftom.bench.backends import make_backend

    opts = options or EvalOptions()
    ds = dataset if isinstance(dataset, Dataset) else load_dataset(dataset)
    root = Path(out)
    with RunLock(root), stop_on_signals():
        owned = backend is None or isinstance(backend, str)
        be = make_backend(backend or "local", workers) if owned else backend
        try:
            return _evaluate(ds, root, opts, be, overwrite, progress)
        finally:
            if owned:
                getattr(be, "shutdown", be.close)()


def _old_run(run_path: Path) -> dict[str, Any]:
    """The run.json of an earlier run in the folder ({} when there is none or it is torn)."""
    if not run_path.is_file():
        return {}
    try:
        old: dict[str, Any] = json.loads(run_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError:
        return {}
    return old


def _done_rows(root: Path, ds: Dataset, prov: Provenance) -> dict[str, dict[str, Any]]:
    """The rows already in ``results.jsonl`` of stimuli of the dataset, by id.

    Raises:
        DatasetError: a row was made by another run (other options, data or code).
    """
    old_rows = _read_jsonl(root / RESULTS, repair=True)
    check_unique((r.get("id") for r in old_rows), root / RESULTS)
    for n, r in enumerate(old_rows, 1):  # every row says how it was made: another run's rows are refused
        differs = provenance_mismatch(Provenance.from_json(r.get("provenance")), prov)
        if differs:
            raise DatasetError(
                f"{root} holds results of another run ({root / RESULTS}:{n} differs in {'; '.join(differs)}); "
                "resume with the same options and code, use another --out folder, or pass --overwrite"
            )
    done = {r["id"]: r for r in old_rows}
    valid = {s.id for s in ds.stimuli}
    return {k: v for k, v in done.items() if k in valid}


class _Sink:
    """The run's appenders: each finished stimulus's caches, timing and row, written at once."""

    def __init__(self, root: Path, prov: Provenance, done: dict[str, dict[str, Any]], total: int,
                 progress: Callable[[int, int], None] | None) -> None:
        self.res_f, self.tr_f, self.team_f, self.tim_f = (
            AtomicAppender(root / n) for n in (RESULTS, TRANSCRIPTS, TEAM_CACHE, TIMINGS))
        self.prov = prov.to_json()
        self.done = done
        self.n_done = len(done)
        self.total = total
        self.progress = progress

    def consume(self, done: _Finished) -> None:
        if done.transcript is not None:
            self.tr_f.write(done.transcript)
        for t in done.team:
            self.team_f.write(t)
        row, timing = _split_timings(done.row)
        row["provenance"] = self.prov
        self.tim_f.write(timing)
        self.res_f.write(row)  # last: a stimulus counts as done once its caches are saved
        self.done[row["id"]] = row
        self.n_done += 1
        if self.progress:
            self.progress(self.n_done, self.total)

    def close(self) -> None:
        for f in (self.res_f, self.tr_f, self.team_f, self.tim_f):
            f.close()


def _split_timings(row: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(row without timing fields, timing record) for a row of the evaluator."""
    models = {m: {k: v for k, v in r.items() if k != "seconds"} for m, r in row.get("models", {}).items()}
    tr = {k: v for k, v in row.get("transcript", {}).items() if k != "rtf"}
    clean = {**row, "models": models, **({"transcript": tr} if "transcript" in row else {})}
    timing = {"id": row["id"], "rtf": row.get("transcript", {}).get("rtf"),
              "seconds": {m: r.get("seconds") for m, r in row.get("models", {}).items()}}
    return clean, timing


def _run_tasks(be: Any, tasks: list[_Task], vocab: tuple[str, ...], sink: _Sink) -> None:
    """Every task, in this process or on the backend's workers, each stimulus into ``sink``."""
    try:
        if sink.progress:
            sink.progress(sink.n_done, sink.total)
        if be.inline:
            for task in tasks:
                for item in _eval_stimuli(task):
                    sink.consume(item)
        else:
            # biggest groups first keeps every worker busy until the end
            order = sorted(tasks, key=lambda t: -len(t.stimuli))
            results = be.map_unordered(_run_task, order, shared=vocab)
            try:
                for _, items in results:
                    for item in items:
                        sink.consume(item)
            finally:
                results.close()
                be.close()
    finally:
        sink.close()


def _evaluate(ds: Dataset, root: Path, opts: EvalOptions, be: Any, overwrite: bool,
              progress: Callable[[int, int], None] | None) -> EvalRun:
    run_info: dict[str, Any] = {"dataset": str(ds.root.resolve()), "dataset_fingerprint": ds.fingerprint,
                "options": opts.to_json(), "seed": opts.seed}
    prov = provenance(opts, ds.fingerprint)
    run_path = root / RUN
    old = _old_run(run_path)
    if overwrite:
        for name in (RESULTS, TRANSCRIPTS, TEAM_CACHE, TIMINGS):
            (root / name).unlink(missing_ok=True)
    t0 = time.perf_counter()
    done = _done_rows(root, ds, prov)
    cached_tr = {t["id"]: t for t in _read_jsonl(root / TRANSCRIPTS, repair=True) if t.get("engine") == opts.engine}
    cached_team: dict[str, dict[str, dict[str, Any]]] = {}
    for t in _read_jsonl(root / TEAM_CACHE, repair=True):
        cached_team.setdefault(t["key"], {})[t["command"]] = t
    _read_jsonl(root / TIMINGS, repair=True)
    pending = [s for s in ds.stimuli if s.id not in done]
    history = [] if overwrite else list(old.get("history", [])) if old.get("dataset_fingerprint") == ds.fingerprint else []
    started = time.strftime("%Y-%m-%dT%H:%M:%S")
    run_info["history"] = history
    run_info["code"] = prov.to_json()["code"]
    _write_json(run_path, run_info)

    vocab = dataset_vocabulary(ds.stimuli)  # every class of every scenario in the dataset
    if is_scene_engine(opts.engine) and pending and be.name == "local":
        _engine(opts.engine, vocab)  # build the LM once, before pool workers fork and race to build it

    groups: OrderedDict[str, list[Stimulus]] = OrderedDict()
    for s in pending:
        groups.setdefault(scenario_key(s), []).append(s)
    tasks = [_Task(str(ds.root), tuple(g), opts, vocab if be.inline else (),
                   {s.id: cached_tr[s.id] for s in g if s.id in cached_tr},
                   cached_team.get(k, {})) for k, g in groups.items()]
    total = len(ds.stimuli)
    _run_tasks(be, tasks, vocab, _Sink(root, prov, done, total, progress))
    seconds = time.perf_counter() - t0
    rows = [done[s.id] for s in ds.stimuli if s.id in done]
    if len(rows) == total:
        rewrite(root / RESULTS, rows)  # manifest order: the same bytes on every backend
    counters = {
        "asr_audio_s": sum(t.get("audio_s", 0.0) for t in cached_tr.values()),
        "team_simulations": sum(1 for _ in _read_jsonl(root / TEAM_CACHE)),
    }
    this = {"started": started, "finished": time.strftime("%Y-%m-%dT%H:%M:%S"), "seconds": round(seconds, 1),
            "resumed": total - len(pending), "evaluated": len(pending), "workers": be.workers,
            "backend": be.name}
    run_info["history"] = [*history, this]
    run_info["seconds"] = round(sum(h["seconds"] for h in run_info["history"]), 1)
    _write_json(run_path, run_info)
    return EvalRun(root, rows, total - len(pending), len(pending), seconds, counters)


def _write_json(path: Path, obj: dict[str, Any]) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(obj, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)
