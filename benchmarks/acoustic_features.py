"""Dump, per stimulus, everything the acoustic likelihood's combination rules need (research tool).

For each stimulus of a dataset: the evaluator's acoustic path (recognition of the whole clip,
``siftom.bench.acoustic_models.heard``), the command list, the
action context log P(command | actions), the N-best phonetic log-likelihood, the key-phrase
alignment scores of a wide candidate set (top ``--wide`` commands by phonetic x context, plus
the top 5 by phonetic alone), the number of phones of each aligned text, the span's length in
frames, and a free phone-loop score of the same span (the background). Rules are then compared
offline (benchmarks/acoustic_rules.py) without aligning again.

    python benchmarks/acoustic_features.py DATASET OUT.jsonl [--wide 8] [--start 0] [--step 2] [--limit N]

(``--start``/``--step`` subsample; the manifest lists clean, 20, 10, 5 dB per speaker, so
``--step 2`` keeps clean and 10 dB and ``--start 1 --step 2`` keeps 20 and 5 dB.) Resumes
when OUT exists.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np


def main(dataset: str, out: str, wide: int = 8, limit: int | None = None, start: int = 0,
         step: int = 1) -> None:
    from _stimulus_record import base_record, done_ids  # benchmarks/ (run as a script)

    from siftom.api import get_model
    from siftom.bench.stimuli import load_dataset
    from siftom.bench.trials import _engine, dataset_vocabulary
    from siftom.likelihood.acoustic import heard_frame, key_phrases
    from siftom.likelihood.registry import get_likelihood
    from siftom.observation import Instruction
    from siftom.speech.acoustic import ForcedAligner
    from siftom.speech.asr.pocketsphinx import cmudict
    from siftom.speech.phoneloop import PhoneLoop

    ds = load_dataset(dataset)
    asr = _engine("pocketsphinx-vocab", dataset_vocabulary(ds.stimuli))
    model = get_model("full", "acoustic")
    phonetic = get_likelihood("phonetic")
    aligner = ForcedAligner()
    loop = PhoneLoop()
    cmu = cmudict()
    p = Path(out)
    done = done_ids(p)
    t0 = time.time()
    with p.open("a") as f:
        for s in ds.stimuli[start:limit:step]:
            if s.id in done:
                continue
            _, instruction, vad, cmds, rec = base_record(ds, s, asr, model)
            ctx = np.asarray(rec["ctx"], dtype=float)
            rec["vad_snr"] = vad.snr_db
            if instruction is None:
                rec["speech"] = False
                f.write(json.dumps(rec) + "\n")
                continue
            phon = np.asarray(phonetic.log_prob(Instruction(nbest=instruction.nbest), cmds), dtype=float)
            q = phon + ctx
            order = np.argsort(-q, kind="stable")
            keep = sorted(set(order[:wide].tolist()) | set(np.argsort(-phon, kind="stable")[:5].tolist()))
            key_words = {w for c in cmds for k, _ in key_phrases(c) for w in k.split()}
            frame = heard_frame(instruction.words or (), key_words)
            rec.update({"speech": True, "nbest": [h.text for h in instruction.nbest],
                        "words": [list(w) for w in (instruction.words or ())],
                        "phon": np.round(phon, 4).tolist(), "keep": keep, "frame": None})
            x = instruction.samples
            if frame is not None:
                st, en, before, after = frame
                seg = x[int(st * 16000):] if en is None else x[int(st * 16000):int(en * 16000)]
                rec["frame"] = [st, en, list(before), list(after)]
                texts = {i: [(" ".join([*before, k, *after]), lp, k) for k, lp in key_phrases(cmds[i])] for i in keep}
            else:
                seg = x
                from siftom.likelihood.acoustic import closest_phrasing
                texts = {i: [(closest_phrasing(cmds[i], instruction.text)[0], 0.0, "")] for i in keep}
            uniq = list(dict.fromkeys(t for v in texts.values() for t, _, _ in v))
            res = aligner.score(seg, uniq)
            sc_of = dict(zip(uniq, res.scores, strict=True))

            def nph(text: str) -> int:
                return sum(len(cmu[w][0]) if w in cmu else 4 for w in text.split())

            rec["align"] = {str(i): [[sc_of[t], lp, nph(k or t), nph(t)] for t, lp, k in v] for i, v in texts.items()}
            rec["frames"] = int(len(seg) / 160)
            rec["loop"] = loop.score(seg)
            f.write(json.dumps(rec) + "\n")
            f.flush()
    print(f"done in {time.time() - t0:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    args = sys.argv[1:]
    kw = {}
    while len(args) > 2 and args[-2].startswith("--"):
        kw[args[-2][2:]] = int(args[-1])
        args = args[:-2]
    main(args[0], args[1], **kw)
