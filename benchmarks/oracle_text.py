"""Accuracy with perfect words: the full model and speech-only on each clean reference.

Run: .venv/bin/python benchmarks/oracle_text.py '{}' DATASET [DATASET ...]
The first argument is a JSON object of PhoneticLikelihood options, e.g. '{"background": false}'
for the channel without the background model; add "_show": N to print N errors (negative N:
errors of the full model). Fast (no audio): one inference per distinct clean stimulus.
"""

from __future__ import annotations

import json
import sys

from siftom.bench.stimuli import load_dataset, scenario_for
from siftom.bench.trials import is_correct
from siftom.inference.model import ModelConfig, Observation, SIFToM
from siftom.likelihood.base import Instruction
from siftom.likelihood.phonetic import PhoneticLikelihood

kw = json.loads(sys.argv[1])
show = kw.pop("_show", 0)
for folder in sys.argv[2:]:
    ds = load_dataset(folder, check_audio=False)
    lk = PhoneticLikelihood(**kw)
    full = SIFToM(ModelConfig(mode="full"), lk)
    so = SIFToM(ModelConfig(mode="speech-only"), lk)
    n = cf = cs = 0
    bad = []
    for s in ds.stimuli:
        if s.noise is not None:
            continue
        sc = scenario_for(s)
        obs = Observation.from_scenario(sc, Instruction.from_text(s.reference))
        a = full.infer(obs).command
        b = a if show < 0 else so.infer(obs).command
        n += 1
        cf += is_correct(a, s.gold_command, sc.verb)
        ok = is_correct(b, s.gold_command, sc.verb)
        cs += ok
        if not ok:
            bad.append((s.reference, s.gold_command, b))
    print(f"{folder}: oracle-text full {100 * cf / n:.1f} % speech-only {100 * cs / n:.1f} % (n={n})")
    for r in bad[: abs(show)]:
        print("   ", r)
