"""Summarise (possibly partial) LLM evaluation runs against the phonetic model on the same stimuli.

Run: .venv/bin/python benchmarks/llm_partial_summary.py RESULTS [BASELINE_RESULTS]
RESULTS is an `siftom eval --out` folder; BASELINE_RESULTS (optional) is a full run of the
default models on the same dataset, used for the phonetic rows when RESULTS has no `siftom`.
Prints n, which scenarios/conditions are covered, accuracy, mean speedup and the mean
seconds per stimulus of each model, on the stimuli present in RESULTS.
"""

from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path


def rows(folder: str) -> dict[str, dict]:
    return {r["id"]: r for r in map(json.loads, (Path(folder) / "results.jsonl").read_text().splitlines())}


def main() -> None:
    main_rows = rows(sys.argv[1])
    base = rows(sys.argv[2]) if len(sys.argv) > 2 else {}
    ids = list(main_rows)
    print(f"n = {len(ids)} stimuli; scenarios: {len({main_rows[i]['scenario'] for i in ids})}; conditions: "
          + ", ".join(f"{k} {v}" for k, v in sorted(Counter(main_rows[i]['condition'].split('@')[0] for i in ids).items())))
    models: dict[str, list[dict]] = {}
    for i in ids:
        for m, v in main_rows[i]["models"].items():
            models.setdefault(m, []).append(v)
        if i in base:
            for m in ("siftom", "literal-asr", "speech-only"):
                if m not in main_rows[i]["models"] and m in base[i]["models"]:
                    models.setdefault(f"{m} (full run, same stimuli)", []).append(base[i]["models"][m])
    print("| model | accuracy | mean speedup | s / stimulus | n |")
    print("|---|---|---|---|---|")
    for m, vs in models.items():
        sp = [v["speedup"] for v in vs if v["speedup"] is not None]
        acc = sum(v["correct"] for v in vs) / len(vs)
        secs = sum(v["seconds"] for v in vs) / len(vs)
        print(f"| {m} | {100 * acc:.1f} % | {sum(sp) / max(len(sp), 1):+.3f} | {secs:.2f} | {len(vs)} |")
    snr = {i: (main_rows[i]["condition"].split("@") + ["clean"])[1] if "@" in main_rows[i]["condition"] else "clean"
           for i in ids}
    levels = sorted(set(snr.values()), key=lambda v: (v != "clean", -float(v.rstrip("dB")) if v != "clean" else 0))
    print("\naccuracy by SNR: | model | " + " | ".join(levels) + " |")
    for m in models:
        cells = []
        for lv in levels:
            vs = [main_rows[i]["models"][m] if m in main_rows[i]["models"] else base[i]["models"][m.split(" ")[0]]
                  for i in ids if snr[i] == lv and (m in main_rows[i]["models"] or i in base)]
            cells.append(f"{100 * sum(v['correct'] for v in vs) / max(len(vs), 1):.0f} % ({len(vs)})")
        print(f"| {m} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
