"""Per-set accuracy by SNR, the gap to the oracle text and the confident-but-wrong rate of eval results.

    python recipes/default_path.py RESULTS_DIR... [--models siftom,siftom-phonetic,siftom-oracle-text]

For each results folder of ``siftom eval``: accuracy % per band (clean, 20, 10, 5 dB) and their
mean per model, and the share of answers that are wrong with probability >= 0.8.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def band(r: dict) -> str:
    return "clean" if r["snr_db"] is None else f"{r['snr_db']:g}"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("results", nargs="+")
    ap.add_argument("--models", default="siftom,siftom-phonetic,siftom-oracle-text")
    ap.add_argument("--threshold", type=float, default=0.8)
    ap.add_argument("--compact", action="store_true", help="one row per set: means, gap to the oracle, confident-wrong")
    a = ap.parse_args()
    if a.compact:
        compact(a.results, a.threshold)
        return
    models = a.models.split(",")
    bands = ["clean", "20", "10", "5"]
    print("| set | model | clean | 20 dB | 10 dB | 5 dB | mean | confident-wrong |")
    print("|---|---|---|---|---|---|---|---|")
    for res in a.results:
        rows = [json.loads(x) for x in (Path(res) / "results.jsonl").read_text().splitlines() if x.strip()]
        for m in models:
            rs = [r for r in rows if m in r["models"]]
            if not rs:
                continue
            acc = {}
            for b in bands:
                sel = [r for r in rs if band(r) == b]
                acc[b] = 100 * sum(r["models"][m]["correct"] for r in sel) / max(1, len(sel))
            mean = sum(acc.values()) / len(bands)
            cw = 100 * sum((not r["models"][m]["correct"]) and r["models"][m]["prob"] >= a.threshold
                           for r in rs) / len(rs)
            print(f"| {Path(res).name} | {m} | " + " | ".join(f"{acc[b]:.1f}" for b in bands)
                  + f" | {mean:.1f} | {cw:.1f} % |")


def compact(results: list[str], threshold: float) -> None:
    bands = ["clean", "20", "10", "5"]
    print("| set | `siftom` (default) | `siftom-phonetic` | oracle text | gap | confident-wrong (default / phonetic) |")
    print("|---|---|---|---|---|---|")
    for res in results:
        rows = [json.loads(x) for x in (Path(res) / "results.jsonl").read_text().splitlines() if x.strip()]

        def mean(m: str, rows: list = rows) -> float:
            return sum(100 * sum(r["models"][m]["correct"] for r in rows if band(r) == b)
                       / max(1, sum(band(r) == b for r in rows)) for b in bands) / len(bands)

        def cw(m: str, rows: list = rows) -> float:
            return 100 * sum((not r["models"][m]["correct"]) and r["models"][m]["prob"] >= threshold
                             for r in rows) / len(rows)

        d, p, o = mean("siftom"), mean("siftom-phonetic"), mean("siftom-oracle-text")
        print(f"| {Path(res).name} ({len(rows)}) | {d:.1f} | {p:.1f} | {o:.1f} | {o - d:.1f} | "
              f"{cw('siftom'):.1f} / {cw('siftom-phonetic'):.1f} % |")


if __name__ == "__main__":
    main()
