"""Sweeps: the cross product of dataset and evaluation settings, on one backend, resumable.

``siftom sweep CONFIG.toml --out DIR`` reads a TOML file::

    [dataset]            # fixed build options (fields of BuildOptions)
    scenarios = 4
    speakers = 2
    [eval]               # fixed evaluation options (fields of EvalOptions)
    nbest = 5
    [axes]               # one list per axis; the sweep runs every combination
    domains = ["household-table-v0", "kitchen-v0"]
    seeds = [0, 1]
    snrs = [[20, 10, 5], [0]]
    models = [["literal-asr", "siftom"]]
    likelihoods = ["phonetic"]

An axis is any field of BuildOptions or EvalOptions, singular or plural (``seeds`` = ``seed``;
``seed`` is the dataset's seed, the bootstrap keeps ``[eval] seed``). Options added to either
later (a phrasing file, a new likelihood) become axes with no change here.

Each distinct dataset is built once in ``DIR/datasets/`` and each cell evaluated in
``DIR/runs/``, both named by a hash of their options, so a rerun resumes where it stopped (a
finished cell costs a few file reads). The sweep writes ``sweep.json``, ``table.md``,
``table.csv`` and ``sweep.png``: accuracy and speedup per cell and model with 95 % bootstrap CIs.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import itertools
import json
import tomllib
import typing
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from siftom.bench.dataset import build_dataset
from siftom.bench.evaluate import EvalOptions, evaluate
from siftom.bench.report import write_report
from siftom.bench.runlock import RunLock, stop_on_signals
from siftom.errors import DatasetError, SiftomError
from siftom.people.stimuli import SPEC, BuildOptions, load_dataset
from siftom.safejson import read_text

BUILD_FIELDS = tuple(f.name for f in dataclasses.fields(BuildOptions))
EVAL_FIELDS = tuple(f.name for f in dataclasses.fields(EvalOptions))
ALIASES = {"domains": "domain", "seeds": "seed", "snr_sets": "snrs", "likelihoods": "likelihood",
           "engines": "engine", "voice_sets": "voices"}
TUPLE_FIELDS = {"voices", "noises", "snrs", "models"}


@dataclasses.dataclass(frozen=True)
class Cell:
    """One combination of the axes: its dataset, its evaluation and where they live."""

    values: dict[str, Any]
    build: BuildOptions
    options: EvalOptions
    dataset_dir: str
    run_dir: str


def _axis_field(key: str) -> str:
    name = ALIASES.get(key, key)
    if name in BUILD_FIELDS or name in EVAL_FIELDS:
        return name
    if name.endswith("s") and (name[:-1] in BUILD_FIELDS or name[:-1] in EVAL_FIELDS):
        return name[:-1]
    raise DatasetError(f"sweep axis {key!r} is not an option of 'dataset build' ({', '.join(BUILD_FIELDS)}) "
                       f"or 'eval' ({', '.join(EVAL_FIELDS)})")


def _coerce(name: str, value: Any) -> Any:
    if name in TUPLE_FIELDS:
        return tuple(value) if isinstance(value, list | tuple) else (value,)
    return value


_HINTS = {**typing.get_type_hints(BuildOptions), **typing.get_type_hints(EvalOptions)}
_KINDS: dict[Any, tuple[str, Callable[[Any], bool]]] = {
    int: ("an integer", lambda v: isinstance(v, int) and not isinstance(v, bool)),
    float: ("a number", lambda v: isinstance(v, int | float) and not isinstance(v, bool)),
    str: ("a string", lambda v: isinstance(v, str)),
    bool: ("true or false", lambda v: isinstance(v, bool)),
}


def _check_type(where: str, name: str, value: Any) -> None:
    """DatasetError naming ``where`` (the TOML key) when ``value`` does not fit option ``name``'s type."""
    hint = _HINTS.get(name, Any)
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    if typing.get_origin(hint) is tuple:  # tuple[X, ...]: a list of X (or one X)
        desc, ok = _KINDS.get(args[0], ("anything", lambda v: True))
        items = value if isinstance(value, list | tuple) else [value]
        bad = next((v for v in items if not ok(v)), None)
        if bad is not None or not items:
            raise DatasetError(f"{where}: {name} must be a list of {desc.removeprefix('an ').removeprefix('a ')}s, "
                               f"got {value!r}")
        return
    kind = hint if hint in _KINDS else (args[0] if len(args) == 1 and args[0] in _KINDS else None)
    if kind is not None and not _KINDS[kind][1](value):
        raise DatasetError(f"{where}: {name} must be {_KINDS[kind][0]}, got {value!r}")


def _hash(obj: Any) -> str:
    return hashlib.sha1(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:10]


@dataclasses.dataclass(frozen=True)
class SweepConfig:
    """A sweep TOML file, checked: the dataset and evaluation options every cell shares (their
    TOML tables), the axes (name -> values) and the sections in the file's order."""

    dataset: dict[str, Any]
    eval: dict[str, Any]
    axes: dict[str, list[Any]]
    sections: tuple[str, ...] = ("dataset", "eval", "axes")

    def to_json(self) -> dict[str, Any]:
        """The ``config`` of ``sweep.json``: the file's sections, in its order."""
        tables: dict[str, Any] = {"dataset": self.dataset, "eval": self.eval, "axes": self.axes}
        return {k: tables[k] for k in self.sections}


@dataclasses.dataclass(frozen=True)
class CellResult:
    """One evaluated cell of ``sweep.json``: its axis values, its dataset and results folders,
    stimuli, and each model's summary (``summary.json``'s ``models``)."""

    values: dict[str, Any]
    dataset: str
    results: str
    n_stimuli: int
    models: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        """The cell's entry in ``sweep.json``."""
        return {"values": self.values, "dataset": self.dataset, "results": self.results,
                "n_stimuli": self.n_stimuli, "models": self.models}


@dataclasses.dataclass(frozen=True)
class SweepResult:
    """``sweep.json``: the configuration and every cell's result, in plan order."""

    config: SweepConfig
    cells: tuple[CellResult, ...]

    def to_json(self) -> dict[str, Any]:
        """The ``sweep.json`` form."""
        return {"config": self.config.to_json(), "cells": [c.to_json() for c in self.cells]}


def load_config(path: str | Path) -> SweepConfig:
    """Read and check a sweep TOML file; raise DatasetError saying what to fix."""
    p = Path(path)
    if not p.is_file():
        raise DatasetError(f"sweep config {str(p)!r} does not exist; see docs/scaling.md for an example")
    try:
        cfg = tomllib.loads(read_text(p, "sweep config", DatasetError))
    except tomllib.TOMLDecodeError as exc:
        raise DatasetError(f"{p}: not valid TOML ({exc})") from None
    unknown = set(cfg) - {"dataset", "eval", "axes"}
    if unknown:
        raise DatasetError(f"{p}: unknown section(s) {', '.join(sorted(unknown))}; use [dataset], [eval] and [axes]")
    axes = cfg.get("axes", {})
    if not isinstance(axes, dict):
        raise DatasetError(f"{p}: [axes] must be a table, e.g. seeds = [0, 1]")
    if not axes:
        raise DatasetError(f"{p}: give at least one axis under [axes], e.g. seeds = [0, 1]")
    for k, v in axes.items():
        if not isinstance(v, list) or not v:
            raise DatasetError(f"{p}: axis {k!r} must be a non-empty list, e.g. {k} = [0, 1]")
        _axis_field(k)
        for v in axes[k]:
            _check_type(f"{p}: [axes] {k}", _axis_field(k), v)
    for section, fields in (("dataset", BUILD_FIELDS), ("eval", EVAL_FIELDS)):
        if not isinstance(cfg.get(section, {}), dict):
            raise DatasetError(f"{p}: [{section}] must be a table of options")
        bad = set(cfg.get(section, {})) - set(fields)
        if bad:
            raise DatasetError(f"{p}: [{section}] has unknown option(s) {', '.join(sorted(bad))}; "
                               f"valid: {', '.join(fields)}")
        for k, v in cfg.get(section, {}).items():
            _check_type(f"{p}: [{section}] {k}", k, v)
    return SweepConfig(dict(cfg.get("dataset", {})), dict(cfg.get("eval", {})), dict(axes), tuple(cfg))


def plan(cfg: SweepConfig, out: str | Path) -> list[Cell]:
    """Every cell of the cross product, in axis order (the last axis varies fastest)."""
    root = Path(out)
    axes = [(k, _axis_field(k), v) for k, v in cfg.axes.items()]
    cells = []
    for combo in itertools.product(*(v for _, _, v in axes)):
        b = {k: _coerce(k, v) for k, v in cfg.dataset.items()}
        e = {k: _coerce(k, v) for k, v in cfg.eval.items()}
        values = {}
        for (key, name, _), v in zip(axes, combo, strict=True):
            (b if name in BUILD_FIELDS else e)[name] = _coerce(name, v)
            values[key] = v
        try:
            bo, eo = BuildOptions(**b), EvalOptions(**e)
        except (SiftomError, TypeError, ValueError) as exc:  # every cell is checked before the first one runs
            raise DatasetError(f"sweep cell {values}: {exc}") from None
        dkey = _hash(bo.to_json())
        ekey = _hash({"dataset": dkey, "eval": eo.to_json(), "seed": eo.seed})
        cells.append(Cell(values, bo, eo, str(root / "datasets" / f"{bo.domain}-{dkey}"),
                          str(root / "runs" / ekey)))
    return cells


def _dataset(cell: Cell, backend: Any) -> Any:
    spec = Path(cell.dataset_dir) / SPEC
    if spec.is_file() and (Path(cell.dataset_dir) / "manifest.jsonl").is_file():
        try:
            if json.loads(spec.read_text(encoding="utf-8")).get("options") == cell.build.to_json():
                return load_dataset(cell.dataset_dir)
        except (json.JSONDecodeError, SiftomError):
            pass  # half-written: build it again (the WAVs already there are kept)
    return build_dataset(cell.build, cell.dataset_dir, backend=backend)


def run_sweep(config: str | Path, out: str | Path, backend: Any,
              progress: Callable[[int, int, Cell], None] | None = None) -> SweepResult:
    """Run (or resume) every cell on ``backend``; write the combined table and figure; return sweep.json."""
    cfg = load_config(config)
    root = Path(out)
    cells = plan(cfg, root)
    done: list[CellResult] = []
    with RunLock(root), stop_on_signals():
        for i, cell in enumerate(cells):
            if progress:
                progress(i, len(cells), cell)
            ds = _dataset(cell, backend)
            evaluate(ds, cell.run_dir, cell.options, backend=backend)
            summary = write_report(cell.run_dir, figures=False)
            done.append(CellResult(cell.values, cell.dataset_dir, cell.run_dir, summary["n_stimuli"],
                                   summary["models"]))
        if progress:
            progress(len(cells), len(cells), cells[-1])
        result = SweepResult(cfg, tuple(done))
        (root / "sweep.json").write_text(json.dumps(result.to_json(), indent=2, default=list) + "\n",
                                         encoding="utf-8")
        rows = table_rows(result)
        (root / "table.md").write_text(markdown_table(rows) + "\n", encoding="utf-8")
        (root / "table.csv").write_text(_csv_table(rows), encoding="utf-8")
        figure(rows, root / "sweep.png")
    return result


def _label(v: Any) -> str:
    return ",".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v) if isinstance(v, list | tuple) else str(v)


@dataclasses.dataclass(frozen=True)
class SweepRow:
    """One model in one cell of the sweep's table: the cell's axis values (as labels), n, and
    accuracy and speedup with their 95 % CIs (None where there is no value)."""

    values: tuple[tuple[str, str], ...]
    model: str
    n: int
    accuracy: float | None
    accuracy_lo: float | None
    accuracy_hi: float | None
    speedup: float | None
    speedup_lo: float | None
    speedup_hi: float | None

    @property
    def cell(self) -> str:
        """The cell's label: its axis values joined."""
        return " / ".join(v for _, v in self.values)

    def to_json(self) -> dict[str, Any]:
        """The row of ``table.csv``: the axis values, then the model and its numbers."""
        return {**dict(self.values), "model": self.model, "n": self.n, "accuracy": self.accuracy,
                "accuracy_lo": self.accuracy_lo, "accuracy_hi": self.accuracy_hi, "speedup": self.speedup,
                "speedup_lo": self.speedup_lo, "speedup_hi": self.speedup_hi}


def table_rows(result: SweepResult) -> list[SweepRow]:
    """One row per cell and model (of ``sweep.json``): the axis values, n, accuracy and speedup with their CIs."""
    rows = []
    for c in result.cells:
        for m, s in c.models.items():
            rows.append(SweepRow(tuple((k, _label(v)) for k, v in c.values.items()), m, s["n"],
                                 s["accuracy"], s["accuracy_ci"][0], s["accuracy_ci"][1],
                                 s["speedup"], s["speedup_ci"][0], s["speedup_ci"][1]))
    return rows


def _f(x: float | None, pct: bool) -> str:
    return "–" if x is None else (f"{100 * x:.1f}" if pct else f"{x:+.3f}")


def markdown_table(rows: Sequence[SweepRow]) -> str:
    """The Markdown table (accuracy in %, speedup, 95 % CIs in brackets)."""
    if not rows:
        return "(no cells)"
    head = [*(k for k, _ in rows[0].values), "model", "n", "accuracy % [95 % CI]", "speedup [95 % CI]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        acc = f"{_f(r.accuracy, True)} [{_f(r.accuracy_lo, True)}, {_f(r.accuracy_hi, True)}]"
        sp = f"{_f(r.speedup, False)} [{_f(r.speedup_lo, False)}, {_f(r.speedup_hi, False)}]"
        lines.append("| " + " | ".join([*(v for _, v in r.values), r.model, str(r.n), acc, sp]) + " |")
    return "\n".join(lines)


def _csv_table(rows: Sequence[SweepRow]) -> str:
    """The same table as CSV (fractions, not percent)."""
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0].to_json()))
        w.writeheader()
        w.writerows(r.to_json() for r in rows)
    return buf.getvalue()


def _stat(row: SweepRow | None, name: str) -> float:
    """A number of a table row (NaN where the row or the number is missing)."""
    v = None if row is None else getattr(row, name)
    return float("nan") if v is None else float(v)


def figure(rows: Sequence[SweepRow], path: Path) -> Path:
    """Accuracy and speedup per cell (groups) and model (bars), with 95 % CI error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    keys = [k for k, _ in rows[0].values]
    cells = list(dict.fromkeys(r.cell for r in rows))
    models = list(dict.fromkeys(r.model for r in rows))
    width = 0.8 / max(1, len(models))
    fig, axes = plt.subplots(2, 1, figsize=(max(6.0, 1.2 * len(cells) * max(1, len(models)) ** 0.5), 7))
    colors = plt.get_cmap("tab10")(np.arange(len(models)) % 10)
    for ax, key, label, scale in ((axes[0], "accuracy", "accuracy (%)", 100.0),
                                  (axes[1], "speedup", "speedup (L_single / L_team − 1)", 1.0)):
        for j, m in enumerate(models):
            mine = {r.cell: r for r in rows if r.model == m}
            x = np.arange(len(cells)) + (j - (len(models) - 1) / 2) * width
            v, lo, hi = (np.array([_stat(mine.get(c), f"{key}{end}") for c in cells]) * scale
                         for end in ("", "_lo", "_hi"))
            ax.bar(x, v, width, yerr=np.abs(np.stack([v - lo, hi - v])), capsize=3, color=colors[j],
                   edgecolor="black", linewidth=0.4, label=m)
        ax.set_xticks(np.arange(len(cells)), cells, rotation=20, ha="right", fontsize=8)
        ax.set_ylabel(label)
        ax.axhline(0, color="black", linewidth=0.6)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylim(0, 100)
    axes[0].legend(fontsize=8, ncol=min(4, len(models)))
    axes[0].set_title(f"sweep over {' / '.join(keys)}; error bars: 95 % bootstrap CI", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
