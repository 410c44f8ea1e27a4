"""Results pages from results files: ``docs/results/*.md`` and the README's table.

Every number the documentation quotes for this version comes from the ``NAME.json`` files that
``siftom bench reproduce`` writes (see :mod:`siftom.bench.reproduce`). The pages are a pure
function of those files: the same files give the same bytes.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from siftom.errors import DatasetError

if TYPE_CHECKING:
    from siftom.bench.reproduce import SetData, SetResult

REPRODUCE = "siftom bench reproduce --plan results/plan.toml --out results/"
PAGES = "siftom bench pages --results results/ --docs docs/results --readme README.md"
START, END = "<!-- results:start -->", "<!-- results:end -->"
README_MODELS = ("literal-asr", "speech-only", "action-only", "siftom", "siftom-acoustic", "siftom-oracle-text")


def load_results(folder: str | Path) -> list[SetResult]:
    """The stamped result files of ``folder`` (``*.json`` with a ``summary``), sorted by set name."""
    from siftom.bench.reproduce import SetResult

    root = Path(folder)
    if not root.is_dir():
        raise DatasetError(f"results folder {str(root)!r} does not exist; run: {REPRODUCE}")
    out = []
    for p in sorted(root.glob("*.json")):
        data = json.loads(p.read_text(encoding="utf-8"))
        if isinstance(data, dict) and "summary" in data and "set" in data:
            out.append(SetResult.from_json(data))
    return out


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _ci(ci: Sequence[float | None] | None) -> str:
    if not ci or ci[0] is None or ci[1] is None:
        return ""
    return f" [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"


def _sp(x: float | None) -> str:
    return "–" if x is None else f"{x:+.3f}"


def versions(results: Sequence[SetResult]) -> list[str]:
    """The siftom versions the results were made with."""
    return sorted({r.siftom for r in results})


def model_order(result: SetResult) -> list[str]:
    """The set's models in the plan's order (the ``--models`` of its eval command), then any others."""
    planned: list[str] = []
    for cmd in result.commands:
        m = re.search(r"--models (\S+)", cmd)
        if m:
            planned = m.group(1).split(",")
    have = result.summary["models"]
    return [m for m in planned if m in have] + sorted(m for m in have if m not in planned)


def set_table(result: SetResult) -> str:
    """One set's table: a row per model, in the plan's order."""
    lines = ["| model | accuracy [95 % CI] | speedup [95 % CI] | negative speedup | helpful errors | n |",
             "|---|---|---|---|---|---|"]
    for m in model_order(result):
        s = result.summary["models"][m]
        sci = s.get("speedup_ci") or [None, None]
        spci = "" if sci[0] is None else f" [{sci[0]:+.3f}, {sci[1]:+.3f}]"
        lines.append(f"| {m} | {_pct(s['accuracy'])}{_ci(s.get('accuracy_ci'))} | {_sp(s['speedup'])}{spci} "
                     f"| {_pct(s.get('neg_speedup_share'))} | {_pct(s.get('helpful_error_share'))} | {s['n']} |")
    return "\n".join(lines)


def voice_table(result: SetResult) -> str:
    """Accuracy per voice (rows) and model (columns, in the plan's order), with the recogniser's
    word error rate per voice; "" when the summary has no per-voice breakdown."""
    summary = result.summary
    by_voice: dict[str, dict[str, Any]] = summary.get("breakdowns", {}).get("voice") or {}
    if not by_voice:
        return ""
    wer: dict[str, float] = summary.get("asr_wer", {}).get("voice") or {}
    models = [m for m in model_order(result) if any(m in row for row in by_voice.values())]
    lines = ["| voice | n | " + " | ".join(models) + " | ASR WER |", "|---|---|" + "---|" * (len(models) + 1)]
    for voice, row in by_voice.items():
        n = max((c.get("n", 0) for c in row.values()), default=0)
        cells = [_pct(row[m]["accuracy"]) if m in row else "" for m in models]
        lines.append(f"| {voice} | {n} | " + " | ".join(cells) + f" | {_pct(wer.get(voice))} |")
    return "\n".join(lines)


def breakdown_table(result: SetResult, by: str, header: str) -> str:
    """Accuracy per group of ``summary["breakdowns"][by]`` (rows) and model (columns, in the plan's
    order); "" when the summary has no such breakdown."""
    groups: dict[str, dict[str, Any]] = result.summary.get("breakdowns", {}).get(by) or {}
    if not groups:
        return ""
    models = [m for m in model_order(result) if any(m in row for row in groups.values())]
    lines = [f"| {header} | n | " + " | ".join(models) + " |", "|---|---|" + "---|" * len(models)]
    for label, row in groups.items():
        n = max((c.get("n", 0) for c in row.values()), default=0)
        lines.append(f"| {label.replace(' @ ', ', ')} | {n} | "
                     + " | ".join(_pct(row[m]["accuracy"]) if m in row else "" for m in models) + " |")
    return "\n".join(lines)


def _rooms_section(result: SetResult) -> str:
    """Accuracy by room and talker distance, and by distance and SNR, for a set built with --rooms."""
    by_room = breakdown_table(result, "room_distance", "room, distance")
    if not by_room:
        return ""
    return ("\n## Accuracy by room and talker distance\n\nEach clip was heard in one simulated room "
            "(`siftom.speech.rooms`) at one talker distance, clean and in noise; n: stimuli per model.\n\n"
            f"{by_room}\n\n{breakdown_table(result, 'distance_snr', 'distance, SNR')}\n")


def _summary_table(results: Sequence[SetResult], models: Sequence[str] = README_MODELS) -> str:
    """Accuracy per set (rows) and model (columns): the README's table."""
    present = [m for m in models if any(m in r.summary["models"] for r in results)]
    lines = ["| set | stimuli | " + " | ".join(present) + " |", "|---|---|" + "---|" * len(present)]
    for r in results:
        ms = r.summary["models"]
        cells = [_pct(ms[m]["accuracy"]) if m in ms else "" for m in present]
        lines.append(f"| {r.title} | {r.dataset.stimuli} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _stamp(results: Sequence[SetResult]) -> str:
    machines = sorted({f"{r.machine.cpus} CPUs, {r.machine.platform}" for r in results})
    return (f"siftom {', '.join(versions(results))}; measured on {'; '.join(machines)}. "
            f"Regenerate: `{REPRODUCE}` (runs everything), then `{PAGES}` (pages only).")


def _worlds(ds: SetData) -> str:
    """``, world seed W`` for a set of generated worlds (``--world-seed``); '' for the registered scenarios."""
    return "" if ds.world_seed is None else f", world seed {ds.world_seed} (generated worlds, none tuned on)"


def _set_page(result: SetResult) -> str:
    """The Markdown page of one set."""
    ds, m = result.dataset, result.machine
    cmds = "\n".join(result.commands)
    return (f"# {result.title}\n\n"
            f"siftom {result.siftom} (source `{result.source_sha1}`); dataset `{ds.domain}`, seed {ds.seed}{_worlds(ds)}, {ds.stimuli} stimuli, "
            f"fingerprint `{ds.fingerprint}`; machine: {m.cpus} CPUs, "
            f"{m.platform}, Python {m.python}.\n\n"
            f"Generated by `{PAGES}` from `results/{result.set}.json`, made by `{REPRODUCE}`:\n\n"
            f"<!-- run: dry -->\n```console\n{cmds}\n```\n\n{set_table(result)}\n{_voice_section(result)}{_rooms_section(result)}")


def _voice_section(result: SetResult) -> str:
    table = voice_table(result)
    if not table:
        return ""
    return ("\n## Accuracy per voice\n\nEach TTS voice's stimuli (every condition of the set); "
            f"n: stimuli per model.\n\n{table}\n")


def _index_page(results: Sequence[SetResult]) -> str:
    """The results overview page."""
    if not results:
        return (f"# Results for this version\n\nNo results files yet. Run `{REPRODUCE}`, then `{PAGES}`.\n")
    links = "\n".join(f"* [{r.title}]({r.set}.md)" for r in results)
    return (f"# Results for this version\n\n{_stamp(results)}\n\nAccuracy (the command executed is the one "
            f"asked for), mean over every condition of the set:\n\n{_summary_table(results)}\n\n"
            f"Each set, with confidence intervals, speedup and the exact commands:\n\n{links}\n")


def _readme_block(results: Sequence[SetResult]) -> str:
    """The README's results block (between the markers)."""
    if not results:
        return f"{START}\nNo results yet: run `make results`.\n{END}"
    return f"{START}\n{_summary_table(results)}\n\n{_stamp(results)}\n{END}"


def write_pages(results_dir: str | Path, docs_dir: str | Path, readme: str | Path | None = None) -> list[Path]:
    """Write ``docs_dir/index.md``, one page per set, and the README block; return what was written."""
    results = load_results(results_dir)
    docs = Path(docs_dir)
    docs.mkdir(parents=True, exist_ok=True)
    written = [docs / "index.md"]
    written[0].write_text(_index_page(results), encoding="utf-8")
    for r in results:
        p = docs / f"{r.set}.md"
        p.write_text(_set_page(r), encoding="utf-8")
        written.append(p)
    if readme is not None:
        path = Path(readme)
        text = path.read_text(encoding="utf-8")
        pattern = re.compile(re.escape(START) + r".*?" + re.escape(END), re.DOTALL)
        if not pattern.search(text):
            raise DatasetError(f"{path} has no {START} ... {END} markers to fill")
        path.write_text(pattern.sub(lambda _m: _readme_block(results), text), encoding="utf-8")
        written.append(path)
    return written
