"""Eval wall time with 1, 2, ... workers on the Ray (or local) backend, and the speedup.

Run: .venv/bin/python recipes/ray_scaling.py [--dataset DIR] [--workers 1,2] [--backend ray]

Builds a 48-stimulus dataset (12 household scenarios x 2 flite speakers x clean + pink 10 dB,
seed 0) in ``runs/scaling/dataset`` unless --dataset is given, then evaluates it from scratch
once per worker count (fresh results folders), on a Ray instance started for that count.
Reports the Ray start-up separately from the evaluation, the 1-minute load average before each
run (other processes on the machine slow every count alike and hide the speedup), and checks
that every run wrote the same results.jsonl.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import time
from pathlib import Path

from siftom.bench.backends import make_backend
from siftom.bench.dataset import build_dataset
from siftom.bench.evaluate import RESULTS, EvalOptions, evaluate
from siftom.people.stimuli import BuildOptions, load_dataset

DEFAULT = BuildOptions(scenarios=12, speakers=2, voices=("flite-slt", "flite-awb"), noises=("pink",),
                       snrs=(10.0,), seed=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default=None, help="dataset folder (default: build one)")
    ap.add_argument("--out", default="runs/scaling", help="work folder")
    ap.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    ap.add_argument("--backend", default="ray", choices=["ray", "local"])
    ap.add_argument("--models", default="literal-asr,speech-only,action-only,siftom,siftom-oracle-text")
    a = ap.parse_args()
    root = Path(a.out)
    ds_dir = Path(a.dataset) if a.dataset else root / "dataset"
    ds = load_dataset(ds_dir) if a.dataset else build_dataset(DEFAULT, ds_dir, workers=2)
    opts = EvalOptions(models=tuple(a.models.split(",")))
    runs = []
    for n in (int(x) for x in a.workers.split(",")):
        out = root / f"{a.backend}-{n}"
        shutil.rmtree(out, ignore_errors=True)
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        be = make_backend(a.backend, n)
        t1 = time.perf_counter()
        try:
            run = evaluate(ds, out, opts, backend=be)
        finally:
            be.shutdown()
        t2 = time.perf_counter()
        runs.append({"workers": n, "start_s": round(t1 - t0, 1), "eval_s": round(t2 - t1, 1),
                     "stimuli": run.evaluated, "load_1min_before": round(load, 1)})
        print(json.dumps(runs[-1]), flush=True)
    same = len({(root / f"{a.backend}-{r['workers']}" / RESULTS).read_bytes() for r in runs}) == 1
    base = runs[0]["eval_s"]
    print(f"\n{len(ds.stimuli)} stimuli, backend {a.backend}, {os.cpu_count()} CPUs; identical results.jsonl: {same}")
    print("| workers | start-up (s) | eval (s) | speedup vs first | load before |")
    print("|---|---|---|---|---|")
    for r in runs:
        print(f"| {r['workers']} | {r['start_s']} | {r['eval_s']} | {base / r['eval_s']:.2f}x | {r['load_1min_before']} |")


if __name__ == "__main__":
    main()
