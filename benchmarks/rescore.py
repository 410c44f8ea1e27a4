"""Re-score the saved N-best lists of eval results folders with other likelihood options.

Run: .venv/bin/python benchmarks/rescore.py '{"content_insert_scale": 0.5}' DATASET RESULTS [DATASET RESULTS ...]
Prints siftom and speech-only accuracy by SNR (mean over clean/20/10/5 dB) without
re-running recognition or team simulations.
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict

from siftom.bench.trials import is_correct, saved_trials
from siftom.inference.model import ModelConfig, Observation, SIFToM
from siftom.likelihood.phonetic import PhoneticLikelihood

kw = json.loads(sys.argv[1])
args = sys.argv[2:]
for dfolder, rfolder in zip(args[::2], args[1::2], strict=True):
    lk = PhoneticLikelihood(**kw)
    models = {"siftom": SIFToM(ModelConfig(mode="full"), lk), "speech-only": SIFToM(ModelConfig(mode="speech-only"), lk)}
    acc: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    for s, sc, r, ins in saved_trials(dfolder, rfolder):
        c = "clean" if r["snr_db"] is None else f"{r['snr_db']:g}"
        for name, m in models.items():
            if ins is None:
                ok = name == "siftom" and r["models"]["siftom"]["correct"]
            else:
                ok = is_correct(m.infer(Observation.from_scenario(sc, ins)).command, s.gold_command, sc.verb)
            acc[name][c].append(ok)
    for name, d in acc.items():
        vals = [100 * sum(d[c]) / len(d[c]) for c in ("clean", "20", "10", "5") if d[c]]
        print(f"{rfolder} {name:12s} " + " ".join(f"{v:5.1f}" for v in vals) + f"  mean {sum(vals) / len(vals):5.1f}")
