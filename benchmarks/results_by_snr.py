"""Accuracy per model by SNR, 1-best WER and object-word error rate from eval results folders.

Run: .venv/bin/python benchmarks/results_by_snr.py RESULTS [RESULTS ...]
"mean" is the equal-weight mean over clean/20/10/5 dB (the overall accuracy of a default
dataset). Object words: names, synonyms, category words and counts of the reference
(siftom.speech.metrics.object_word_errors).
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict

from siftom.likelihood.background import lexicon_words
from siftom.likelihood.lexicon import default_lexicon
from siftom.speech.metrics import object_word_errors

OBJECT_WORDS = lexicon_words(default_lexicon())
CONDS = ("clean", "20", "10", "5")

for folder in sys.argv[1:]:
    with open(f"{folder}/results.jsonl", encoding="utf-8") as f:
        rows = [json.loads(line) for line in f if line.strip()]
    acc: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    wer: dict[str, list[float]] = defaultdict(list)
    oe: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in rows:
        c = "clean" if r["snr_db"] is None else f"{r['snr_db']:g}"
        wer[c].append(r["transcript"]["wer"])
        e, n = object_word_errors(r["reference"], r["transcript"]["text"], OBJECT_WORDS)
        oe[c][0] += e
        oe[c][1] += n
        for m, v in r["models"].items():
            acc[m][c].append(v["correct"])
    conds = [c for c in CONDS if wer[c]]
    print(f"{folder} (n={len(rows)})")
    print("  WER %          " + " ".join(f"{100 * sum(wer[c]) / len(wer[c]):5.0f}" for c in conds))
    print("  object err %   " + " ".join(f"{100 * oe[c][0] / max(1, oe[c][1]):5.0f}" for c in conds))
    for m, d in acc.items():
        vals = [100 * sum(d[c]) / len(d[c]) for c in conds]
        print(f"  {m:20s} " + " ".join(f"{v:5.1f}" for v in vals) + f"  mean {sum(vals) / len(vals):5.1f}")
