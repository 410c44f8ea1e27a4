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

import re
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from siftom.bench.constants import constants_table
from siftom.bench.pages import _ci, _pct, load_results, model_order, set_table
from siftom.errors import DatasetError

FILL = ("siftom bench pages --fill docs/benchmark.md --fill docs/explanation/constants.md --fill docs/decisions.md "
        "--fill docs/streaming.md")
BLOCK = re.compile(r"<!-- gen:(?P<spec>.*?) -->(?P<body>.*?)<!-- /gen -->", re.DOTALL)
SNR_ORDER = ("clean", "20 dB", "10 dB", "5 dB", "0 dB")


def _get(result: dict[str, Any], path: str) -> Any:
    node: Any = result["summary"]
    for key in path.split("/"):
        if not isinstance(node, dict) or key not in node:
            raise DatasetError(f"results/{result['set']}.json has no summary/{path} (at {key!r})")
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


def _snr_table(result: dict[str, Any], models: Sequence[str], wer: bool = True) -> str:
    """Accuracy per condition (rows) and model (columns), with the 1-best WER."""
    snr = result["summary"]["breakdowns"]["snr"]
    conds = [c for c in SNR_ORDER if c in snr] + sorted(c for c in snr if c not in SNR_ORDER)
    wers = result["summary"].get("asr_wer", {}).get("snr", {})
    head = ["condition"] + (["WER"] if wer else []) + list(models)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in conds:
        cells = [c] + ([_pct(wers.get(c))] if wer else [])
        cells += [_pct(snr[c][m]["accuracy"]) if m in snr[c] else "" for m in models]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _trials_block(rows: Sequence[dict[str, Any]], name: str) -> str:
    """The whole-trial summary of ``rows`` as a table, stamped with the version and machine."""
    from siftom.bench.wholetrial import markdown, summarise

    versions = sorted({str(r.get("version", "?")) for r in rows})
    machines = sorted({f"{r['machine'].get('cpu_count')} CPUs, {r['machine'].get('platform')}"
                       for r in rows if isinstance(r.get("machine"), dict)}) or ["not recorded"]
    seeds = sorted({int(r["seed"]) for r in rows})
    return (f"\n{markdown(summarise(rows))}\n\n{len(rows)} trials, seeds {seeds[0]}–{seeds[-1]}; siftom "
            f"{', '.join(versions)}; measured on {'; '.join(machines)}. Regenerated from "
            f"`results/trials/{name}.jsonl` by `make pages`.\n")


def load_trials(folder: str | Path) -> dict[str, list[dict[str, Any]]]:
    """``NAME.jsonl`` whole-trial rows per NAME in ``folder`` (none when it does not exist)."""
    import json

    out: dict[str, list[dict[str, Any]]] = {}
    for path in sorted(Path(folder).glob("*.jsonl")) if Path(folder).is_dir() else []:
        with path.open(encoding="utf-8") as f:
            out[path.stem] = [json.loads(line) for line in f if line.strip()]
    return out


def load_service(folder: str | Path) -> dict[str, dict[str, Any]]:
    """``NAME.json`` service benchmark results per NAME in ``folder`` (none when it does not exist)."""
    import json

    folder = Path(folder)
    return {p.stem: json.loads(p.read_text(encoding="utf-8")) for p in sorted(folder.glob("*.json"))} \
        if folder.is_dir() else {}


def _stamp(results: Sequence[dict[str, Any]]) -> str:
    ms = [r.get("machine", {}) for r in results]
    versions = sorted({str(m.get("version", "?")) for m in ms})
    where = sorted({f"{m.get('cpus')} CPUs ({m.get('processor')})" for m in ms})
    return f"siftom {', '.join(versions)}; measured on {'; '.join(where)}"


def _service_block(kind: str, service: dict[str, dict[str, Any]]) -> str:
    """A table of ``siftom bench robots`` (``robots``) or ``siftom bench hostile`` (``hostile``) results."""
    if kind == "robots":
        runs = [(n, r) for n, r in service.items() if n.startswith("robots-")]
        if not runs:
            raise DatasetError("gen:service robots: no results/service/robots-*.json; write them with "
                               "siftom bench robots --out")
        lines = ["| run | streams × instructions | decisions | delay p50 / p90 (s) | /v1/infer p90 idle → load (ms) "
                 "| ratio | in-process p50 (s) | load before |", "|---|---|---|---|---|---|---|---|"]
        for name, r in runs:
            o = r["options"]
            ratio = r["load_infer_ms"]["p90"] / r["idle_infer_ms"]["p90"] if r["load_infer_ms"].get("n") else None
            local = r.get("in_process") or {}
            loaded = r["load_infer_ms"]["p90"] if r["load_infer_ms"].get("n") else "–"
            lines.append(f"| {name} | {o['streams']} × {o['instructions']} | {r['answered']}/{r['expected']} | "
                         f"{r['delay_p50_s']} / {r['delay_p90_s']} | {r['idle_infer_ms']['p90']} → "
                         f"{loaded} | {'–' if ratio is None else f'{ratio:.1f}×'} | "
                         f"{local.get('p50_s', '–')} | {r['machine'].get('load_avg_before', ['?'])[0]} |")
        return "\n" + "\n".join(lines) + f"\n\n{_stamp([r for _, r in runs])}. Regenerated from " \
            "`results/service/robots-*.json` by `make pages`.\n"
    if kind == "hostile":
        if "hostile" not in service:
            raise DatasetError("gen:service hostile: no results/service/hostile.json; write it with "
                               "siftom bench hostile --out")
        r = service["hostile"]
        lines = ["| input | status | answered in (s) | slowest /healthz meanwhile (ms) | says |", "|---|---|---|---|---|"]
        lines += [f"| {x['input']} | {x['status']} | {x['seconds']} | {x['healthz_max_ms']} | "
                  f"{x['detail'][:70].replace('|', '/')}… |" for x in r["rows"]]
        return "\n" + "\n".join(lines) + f"\n\n{_stamp([r])}. Regenerated from `results/service/hostile.json` " \
            "by `make pages`.\n"
    raise DatasetError(f"gen:service {kind}: use robots or hostile")


def render(spec: str, results: dict[str, dict[str, Any]], trials: dict[str, list[dict[str, Any]]] | None = None,
           service: dict[str, dict[str, Any]] | None = None) -> str:
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
        return _service_block(name, service or {})
    if kind == "trials":
        if not trials or name not in trials:
            raise DatasetError(f"gen:{spec}: no results/trials/{name}.jsonl (have: "
                               f"{', '.join(sorted(trials or {})) or 'none'}); write it with siftom bench trials --out")
        return _trials_block(trials[name], name)
    if name not in results:
        raise DatasetError(f"gen:{spec}: no results/{name}.json (have: {', '.join(sorted(results)) or 'none'})")
    r = results[name]
    pos, kw = _opts(rest[1:])
    models = kw["models"].split(",") if "models" in kw else model_order(r)
    if kind == "table":
        sub = dict(r, summary=dict(r["summary"], models={m: r["summary"]["models"][m] for m in models}))
        return "\n" + set_table(sub) + "\n"
    if kind == "snr":
        return "\n" + _snr_table(r, models, wer="wer" in pos) + "\n"
    if kind == "value" and len(pos) == 2:
        return _fmt(_get(r, pos[0]), pos[1])
    if kind == "diff" and len(pos) == 3:
        return _fmt(_get(r, pos[0]) - _get(r, pos[1]), pos[2])
    raise DatasetError(f"bad gen: block {spec!r} (see siftom.bench.blocks)")


def fill_page(text: str, results: Sequence[dict[str, Any]],
              trials: dict[str, list[dict[str, Any]]] | None = None,
              service: dict[str, dict[str, Any]] | None = None) -> str:
    """``text`` with every generated block rewritten."""
    by_set = {r["set"]: r for r in results}
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
