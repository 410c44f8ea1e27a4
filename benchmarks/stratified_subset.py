"""A stratified subset of a benchmark dataset: every scenario and condition, speakers in rotation.

Run: .venv/bin/python benchmarks/stratified_subset.py DATASET OUT [ROUNDS [FIRST]]
Writes OUT/manifest.jsonl, OUT/dataset.json and OUT/audio (a link to DATASET/audio). Round r
keeps, for scenario k (in manifest order), every condition spoken by speaker number
(k + r) mod S; ROUNDS=1 gives 26 scenarios x 4 conditions = 104 of the 520 stimuli, each speaker
about equally often. With FIRST, rounds FIRST..ROUNDS-1 only (``5 4`` is the fifth round
alone): disjoint rounds 0..4 partition the dataset, so they can run one after another and a run
stopped early still covers every scenario and condition. Used to evaluate slow models (the in-process LLM) on a representative
part of a dataset when the whole one does not fit the time available.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path


def main() -> None:
    src, out = Path(sys.argv[1]), Path(sys.argv[2])
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    first = int(sys.argv[4]) if len(sys.argv) > 4 else 0
    rows = [json.loads(line) for line in (src / "manifest.jsonl").read_text().splitlines() if line.strip()]
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    speakers = sorted({r["speaker"] for r in rows})
    keep = {(sc, speakers[(k + r) % len(speakers)]) for k, sc in enumerate(scenarios) for r in range(first, rounds)}
    chosen = [r for r in rows if (r["scenario"], r["speaker"]) in keep]
    out.mkdir(parents=True, exist_ok=True)
    (out / "manifest.jsonl").write_text("".join(json.dumps(r) + "\n" for r in chosen))
    shutil.copy(src / "dataset.json", out / "dataset.json")
    if not (out / "audio").exists():
        (out / "audio").symlink_to((src / "audio").resolve())
    print(f"{len(chosen)} of {len(rows)} stimuli ({len(scenarios)} scenarios x {rounds - first} speaker(s)) -> {out}")


if __name__ == "__main__":
    main()
