"""Dump, per stimulus, what the Whisper teacher-forced factor's combination rules need (research tool).

For each stimulus: the evaluator's acoustic path (``siftom.bench.acoustic_models.heard``), the
commands, the action context log P(command | actions), the N-best phonetic log-likelihood,
the shipped acoustic likelihood (``acoustic`` with ``whisper=False``: alignment x phonetic,
pruned by the context, as ``siftom-acoustic`` scored before the Whisper factor), and the Whisper
teacher-forced score (``siftom.speech.whisper_score``) of the texts of the pruned commands and
the ``--wide`` best by phonetic x context (``wide``) — each key
phrase put in place of the heard key words of the recogniser's 1-best (or, when no key word was
heard, the command's phrasing closest to the 1-best) — for each padding in ``--pads``, and the same texts against digital silence of the clip's length
(``w0``: what Whisper's decoder expects with no speech, its text prior).
Rules are then compared offline (benchmarks/whisper_rules.py).

    python benchmarks/whisper_features.py DATASET OUT.jsonl [--pads 0.01,3] [--limit N] [--wide 10]

Resumes when OUT exists.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("out")
    ap.add_argument("--pads", default="0.01,3")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--wide", type=int, default=10)
    a = ap.parse_args()
    from _stimulus_record import base_record, done_ids  # benchmarks/ (run as a script)

    from siftom.api import get_model
    from siftom.bench.stimuli import load_dataset
    from siftom.bench.trials import _engine, dataset_vocabulary
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.likelihood.registry import get_likelihood
    from siftom.likelihood.whisper_factor import candidate_texts
    from siftom.observation import Instruction
    from siftom.speech.whisper_score import WhisperScorer

    ds = load_dataset(a.dataset)
    asr = _engine("pocketsphinx-vocab", dataset_vocabulary(ds.stimuli))
    model = get_model("full", "acoustic")
    phonetic = get_likelihood("phonetic")
    acoustic = AcousticLikelihood(whisper=False)
    pads = [float(p) for p in a.pads.split(",")]
    scorers = {p: WhisperScorer(pad_s=p, cpu_threads=1) for p in pads}
    p = Path(a.out)
    done = done_ids(p)
    t0 = time.time()
    with p.open("a") as f:
        for s in ds.stimuli[: a.limit]:
            if s.id in done:
                continue
            _, instruction, _, cmds, rec = base_record(ds, s, asr, model)
            ctx = np.asarray(rec["ctx"], dtype=float)
            if instruction is None:
                rec["speech"] = False
                f.write(json.dumps(rec) + "\n")
                continue
            phon = np.asarray(phonetic.log_prob(Instruction(nbest=instruction.nbest), cmds), dtype=float)
            ac = acoustic.log_prob(instruction, cmds, context=ctx)
            keep = acoustic.candidates(instruction, cmds, ctx, phon)
            # score the pruned set and the next ones by phonetic x context (others: see whisper_rules)
            wide = sorted(set(keep.tolist()) | set(np.argsort(-(phon + ctx), kind="stable")[:a.wide].tolist()))
            texts, mode = candidate_texts(instruction, cmds, wide)
            uniq = list(dict.fromkeys(t for v in texts for t, _ in v))
            rec.update({"speech": True, "nbest": [h.text for h in instruction.nbest], "mode": mode,
                        "phon": np.round(phon, 4).tolist(), "ac": np.round(ac, 4).tolist(),
                        "keep": keep.tolist(), "wide": wide, "w": {}})
            for pad, ws in scorers.items():
                tw = time.perf_counter()
                sc_of = dict(zip(uniq, ws.score(instruction.samples, uniq).tolist(), strict=True))
                rec["w"][str(pad)] = [[[sc_of[t], lp] for t, lp in v] for v in texts]
                # the same texts against digital silence of the same length: Whisper's text prior
                z0 = dict(zip(uniq, ws.score(np.zeros_like(instruction.samples), uniq).tolist(), strict=True))
                rec.setdefault("w0", {})[str(pad)] = [[[z0[t], lp] for t, lp in v] for v in texts]
                rec[f"w_s_{pad}"] = round(time.perf_counter() - tw, 4)
            f.write(json.dumps(rec) + "\n")
            f.flush()
    print(f"done in {time.time() - t0:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
