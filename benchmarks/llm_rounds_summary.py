"""One table for evaluation runs split into stratified rounds (slow LLM models).

Run: .venv/bin/python benchmarks/llm_rounds_summary.py RESULTS [RESULTS ...]
Each RESULTS is an `siftom eval --out` folder of one round (benchmarks/stratified_subset.py with
FIRST, so rounds are disjoint); their rows are pooled (an id seen twice is an error) and
summarised like `siftom report` (accuracy and speedup with bootstrap CIs), with each model's mean
seconds per stimulus from timings.jsonl (mean and median: a run paused
or starved by other jobs inflates the mean) and the accuracy by SNR.
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from pathlib import Path

from siftom.bench.report import main_table, summarise


def main() -> None:
    rows: dict[str, dict] = {}
    secs: dict[str, list[float]] = defaultdict(list)
    for folder in sys.argv[1:]:
        for line in (Path(folder) / "results.jsonl").read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                if r["id"] in rows:
                    raise SystemExit(f"{r['id']} is in two folders; give disjoint rounds")
                rows[r["id"]] = r
        timings = Path(folder) / "timings.jsonl"
        if timings.is_file():
            for line in timings.read_text().splitlines():
                if line.strip():
                    for m, v in json.loads(line)["seconds"].items():
                        if v is not None:
                            secs[m].append(v)
    summary = summarise(list(rows.values()))
    print(f"n = {len(rows)} stimuli, {len({r['scenario'] for r in rows.values()})} scenarios\n")
    print(main_table(summary))
    print("\n| model | s / stimulus, mean | median |\n|---|---|---|")
    for m, v in secs.items():
        print(f"| {m} | {sum(v) / len(v):.2f} | {sorted(v)[len(v) // 2]:.2f} |")
    snr = summary["breakdowns"].get("snr", {})  # {level: {model: {...}}}
    if snr:
        levels = list(snr)
        print("\n| accuracy by SNR | " + " | ".join(levels) + " |\n|---|" + "---|" * len(levels))
        for m in summary["models"]:
            cells = [f"{100 * snr[lv][m]['accuracy']:.0f} % ({snr[lv][m]['n']})" if m in snr[lv] else "–"
                     for lv in levels]
            print(f"| {m} | " + " | ".join(cells) + " |")

if __name__ == "__main__":
    main()
