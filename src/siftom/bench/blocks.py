"""Generated blocks inside hand-written docs pages: numbers from results files, constants from code.

A page holds ``<!-- gen:SPEC -->`` … ``<!-- /gen -->``; :func:`fill_page` rewrites what lies
between the markers from ``results/*.json`` (:mod:`siftom.bench.pages`) or the constants
registry (:mod:`siftom.bench.constants`), and leaves every other byte as it is. SPEC is split
like a shell line (quote a key with spaces):

* ``constants`` — the table of tuned constants;
* ``table SET [models=a,b]`` — one set's model table (accuracy, speedup, CIs, n);
* ``snr SET models=a,b [wer]`` — accuracy per condition, with the 1-best WER column;
* ``value SET PATH FORMAT`` — one number inline; PATH is ``/``-separated inside the set's
  ``summary`` (``models/siftom/accuracy``, ``"breakdowns/snr/10 dB/siftom/accuracy"``);
* ``diff SET PATH PATH FORMAT`` — the first number minus the second;
* ``trials NAME`` — the whole-trial table of ``results/trials/NAME.jsonl`` (written by
  ``siftom bench trials --out``), per channel, person policy and rule, with its version and machine.

FORMAT: ``pct`` (61.2 %), ``pct0`` (61 %), ``pts`` (+18.7, percentage points), ``num`` (61.2,
a share as a percentage without the sign), ``sp`` (+0.190), ``int``, ``ci`` ([56.9, 65.2]).
"""

from __future__ import annotations

import dataclasses
import json
import re
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from siftom.bench.constants import constants_table
from siftom.bench.hostile import HostileResult
from siftom.bench.machine import Machine
from siftom.bench.pages import _ci, _pct, load_results, model_order, set_table
from siftom.bench.reproduce import SetResult
from siftom.bench.robots import ServeBenchResult
from siftom.errors import DatasetError

FILL = ("siftom bench pages --fill docs/benchmark.md --fill docs/explanation/constants.md --fill docs/decisions.md "
        "--fill docs/streaming.md")
BLOCK = re.compile(r"<!-- gen:(?P<spec>.*?) -->(?P<body>.*?)<!-- /gen -->", re.DOTALL)
SNR_ORDER = ("clean", "20 dB", "10 dB", "5 dB", "0 dB")


@dataclass(frozen=True)
class TrialBatch:
    """A ``results/trials/NAME.jsonl`` file: whole-trial rows as ``siftom bench trials --out`` wrote
    them (:func:`siftom.bench.wholetrial.run_trials`), one a line."""

    name: str
    rows: tuple[dict[str, Any], ...]

    @classmethod
    def read(cls, path: Path) -> TrialBatch:
        """Read ``path`` (its stem names the batch)."""
        with path.open(encoding="utf-8") as f:
            return cls(path.stem, tuple(json.loads(line) for line in f if line.strip()))


@dataclass(frozen=True)
class ServiceResults:
    """The service benchmarks' results of ``results/service``: every ``robots-*.json`` (``siftom bench
    robots --out``) by name, and ``hostile.json`` (``siftom bench hostile --out``) when there is one."""

    robots: tuple[tuple[str, ServeBenchResult], ...] = ()
    hostile: HostileResult | None = None


def _get(result: SetResult, path: str) -> Any:
    node: Any = result.summary
    for key in path.split("/"):
        if not isinstance(node, dict) or key not in node:
            raise DatasetError(f"results/{result.set}.json has no summary/{path} (at {key!r})")
        node = node[key]
    return node


def _fmt(x: Any, how: str) -> str:
    if how == "ci":
        return _ci(x).strip()
    if x is None:
        return "–"
    if how == "pct":
        return _pct(x)
    if how == "pct0":
        return f"{100 * x:.0f} %"
    if how == "num":
        return f"{100 * x:.1f}"
    if how == "pts":
        return f"{100 * x:+.1f}"
    if how == "sp":
        return f"{x:+.3f}"
    if how == "int":
        return f"{int(x)}"
    raise DatasetError(f"unknown format {how!r} (pct, pct0, num, pts, sp, int, ci)")


def _opts(args: Sequence[str]) -> tuple[list[str], dict[str, str]]:
    pos = [a for a in args if "=" not in a]
    kw = dict(a.split("=", 1) for a in args if "=" in a)
    return pos, kw


def _snr_table(result: SetResult, models: Sequence[str], wer: bool = True) -> str:
    """Accuracy per condition (rows) and model (columns), with the 1-best WER."""
    snr = result.summary["breakdowns"]["snr"]
    conds = [c for c in SNR_ORDER if c in snr] + sorted(c for c in snr if c not in SNR_ORDER)
    wers = result.summary.get("asr_wer", {}).get("snr", {})
    head = ["condition"] + (["WER"] if wer else []) + list(models)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in conds:
        cells = [c] + ([_pct(wers.get(c))] if wer else [])
        cells += [_pct(snr[c][m]["accuracy"]) if m in snr[c] else "" for m in models]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _trials_block(batch: TrialBatch) -> str:
    """The whole-trial summary of a batch as a table, stamped with the version and machine."""
    from siftom.bench.wholetrial import markdown, summarise

    rows, name = batch.rows, batch.name
    versions = sorted({str(r.get("version", "?")) for r in rows})
    machines = sorted({f"{r['machine'].get('cpu_count')} CPUs, {r['machine'].get('platform')}"
                       for r in rows if isinstance(r.get("machine"), dict)}) or ["not recorded"]
    seeds = sorted({int(r["seed"]) for r in rows})
    return (f"\n{markdown(summarise(rows))}\n\n{len(rows)} trials, seeds {seeds[0]}–{seeds[-1]}; siftom "
            f"{', '.join(versions)}; measured on {'; '.join(machines)}. Regenerated from "
            f"`results/trials/{name}.jsonl` by `make pages`.\n")


def load_trials(folder: str | Path) -> dict[str, TrialBatch]:
    """The ``NAME.jsonl`` whole-trial batches of ``folder`` by NAME (none when it does not exist)."""
    paths = sorted(Path(folder).glob("*.jsonl")) if Path(folder).is_dir() else []
    return {p.stem: TrialBatch.read(p) for p in paths}


def load_service(folder: str | Path) -> ServiceResults:
    """The service benchmarks' results in ``folder`` (none when it does not exist)."""
    folder = Path(folder)
    paths = sorted(folder.glob("*.json")) if folder.is_dir() else []
    robots = tuple((p.stem, ServeBenchResult.from_json(json.loads(p.read_text(encoding="utf-8"))))
                   for p in paths if p.stem.startswith("robots-"))
    hostile = next((HostileResult.from_json(json.loads(p.read_text(encoding="utf-8")))
                    for p in paths if p.stem == "hostile"), None)
    return ServiceResults(robots, hostile)


def _stamp(machines: Sequence[Machine]) -> str:
    versions = sorted({m.version or "?" for m in machines})
    where = sorted({f"{m.cpus} CPUs ({m.processor})" for m in machines})
    return f"siftom {', '.join(versions)}; measured on {'; '.join(where)}"


def _service_block(kind: str, service: ServiceResults) -> str:
    """A table of ``siftom bench robots`` (``robots``) or ``siftom bench hostile`` (``hostile``) results."""
    if kind == "robots":
        runs = service.robots
        if not runs:
            raise DatasetError("gen:service robots: no results/service/robots-*.json; write them with "
                               "siftom bench robots --out")
        lines = ["| run | streams × instructions | decisions | delay p50 / p90 (s) | /v1/infer p90 idle → load (ms) "
                 "| ratio | in-process p50 (s) | load before |", "|---|---|---|---|---|---|---|---|"]
        for name, r in runs:
            o, idle, load = r.options, r.idle_infer_ms, r.load_infer_ms
            ratio = load["p90"] / idle["p90"] if load.get("n") else None
            local = r.in_process or {}
            loaded = load["p90"] if load.get("n") else "–"
            lines.append(f"| {name} | {o['streams']} × {o['instructions']} | {r.answered}/{r.expected} | "
                         f"{r.delay_p50_s} / {r.delay_p90_s} | {idle['p90']} → "
                         f"{loaded} | {'–' if ratio is None else f'{ratio:.1f}×'} | "
                         f"{local.get('p50_s', '–')} | {(r.machine.load_avg or ('?',))[0]} |")
        return "\n" + "\n".join(lines) + f"\n\n{_stamp([r.machine for _, r in runs])}. Regenerated from " \
            "`results/service/robots-*.json` by `make pages`.\n"
    if kind == "hostile":
        h = service.hostile
        if h is None:
            raise DatasetError("gen:service hostile: no results/service/hostile.json; write it with "
                               "siftom bench hostile --out")
        lines = ["| input | must get | got | answered in (s) | slowest /healthz meanwhile (ms) | says |",
                 "|---|---|---|---|---|---|"]
        for x in h.rows:
            must = f"{'4xx' if x.expect == 0 else x.expect} within {x.within_s:g} s"
            got = str(x.status) if x.ran else "not run"
            health = "–" if x.healthz_max_ms is None else x.healthz_max_ms
            lines.append(f"| {x.input} | {must} | {got} | {x.seconds} | {health} | "
                         f"{x.detail[:70].replace('|', '/')}… |")
        busy = f" (load average {h.machine.load_avg[0]} before the run)" if h.machine.load_avg else ""
        verdict = "every case met its floor" if h.meets else "not every case met its floor"
        return "\n" + "\n".join(lines) + f"\n\n{_stamp([h.machine])}{busy}: {verdict}. Regenerated from " \
            "`results/service/hostile.json` by `make pages`.\n"
    raise DatasetError(f"gen:service {kind}: use robots or hostile")


def render(spec: str, results: Mapping[str, SetResult], trials: Mapping[str, TrialBatch] | None = None,
           service: ServiceResults | None = None) -> str:
    """What a block with ``spec`` holds."""
    args = shlex.split(spec)
    if not args:
        raise DatasetError("empty gen: block")
    kind, rest = args[0], args[1:]
    if kind == "constants":
        return "\n" + constants_table() + "\n"
    if not rest:
        raise DatasetError(f"gen:{kind} needs a set name")
    name = rest[0]
    if kind == "service":
        return _service_block(name, service or ServiceResults())
    if kind == "trials":
        if not trials or name not in trials:
            raise DatasetError(f"gen:{spec}: no results/trials/{name}.jsonl (have: "
                               f"{', '.join(sorted(trials or {})) or 'none'}); write it with siftom bench trials --out")
        return _trials_block(trials[name])
    if name not in results:
        raise DatasetError(f"gen:{spec}: no results/{name}.json (have: {', '.join(sorted(results)) or 'none'})")
    r = results[name]
    pos, kw = _opts(rest[1:])
    models = kw["models"].split(",") if "models" in kw else model_order(r)
    if kind == "table":
        sub = dataclasses.replace(r, summary={**r.summary, "models": {m: r.summary["models"][m] for m in models}})
        return "\n" + set_table(sub) + "\n"
    if kind == "snr":
        return "\n" + _snr_table(r, models, wer="wer" in pos) + "\n"
    if kind == "value" and len(pos) == 2:
        return _fmt(_get(r, pos[0]), pos[1])
    if kind == "diff" and len(pos) == 3:
        return _fmt(_get(r, pos[0]) - _get(r, pos[1]), pos[2])
    raise DatasetError(f"bad gen: block {spec!r} (see siftom.bench.blocks)")


def fill_page(text: str, results: Sequence[SetResult], trials: Mapping[str, TrialBatch] | None = None,
              service: ServiceResults | None = None) -> str:
    """``text`` with every generated block rewritten."""
    by_set = {r.set: r for r in results}
    return BLOCK.sub(lambda m: f"<!-- gen:{m['spec']} -->{render(m['spec'], by_set, trials, service)}<!-- /gen -->",
                     text)


def fill_pages(results_dir: str | Path, pages: Sequence[str | Path]) -> list[Path]:
    """Rewrite the generated blocks of ``pages`` in place; return the pages that hold any."""
    results = load_results(results_dir)
    trials = load_trials(Path(results_dir) / "trials")
    service = load_service(Path(results_dir) / "service")
    out = []
    for page in pages:
        path = Path(page)
        text = path.read_text(encoding="utf-8")
        if not BLOCK.search(text):
            raise DatasetError(f"{path} has no <!-- gen:... --> ... <!-- /gen --> block to fill")
        new = fill_page(text, results, trials, service)
        if new != text:
            path.write_text(new, encoding="utf-8")
        out.append(path)
    return out
