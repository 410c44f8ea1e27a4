"""How confident should the acoustic likelihood be?  Re-weight it offline: P ∝ prior · actions · L^γ.

    python recipes/acoustic_weight.py collect DATASET OUT.jsonl [--start 0 --step 2]
    python recipes/acoustic_weight.py score OUT.jsonl... [--gammas 1,0.8,0.7,0.6,0.5]

``collect`` runs the default path (full model, acoustic likelihood) once per stimulus and stores
the joint log terms; ``score`` gives accuracy, the share wrong with P >= 0.8 and the mean NLL of
the gold command for each γ, per band.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


class _Recorded:
    uses_context = True
    name = "acoustic-recorded"

    def __init__(self) -> None:
        from siftom.likelihood.acoustic import AcousticLikelihood

        self.inner = AcousticLikelihood()
        self.last = None

    def log_prob(self, instruction, commands, context=None):
        self.last = np.asarray(self.inner.log_prob(instruction, commands, context=context), dtype=float)
        return self.last


def collect(dataset: str, out: str, start: int, step: int) -> None:
    from siftom.bench.acoustic_models import heard
    from siftom.bench.trials import dataset_vocabulary
    from siftom.inference.model import ModelConfig, Observation, SIFToM
    from siftom.people.stimuli import load_dataset, scenario_for
    from siftom.speech.asr.base import get_engine

    ds = load_dataset(dataset)
    engine = get_engine("pocketsphinx-vocab", vocabulary=dataset_vocabulary(ds.stimuli))
    rec = _Recorded()
    model = SIFToM(ModelConfig("full"), rec)
    done = {json.loads(x)["id"] for x in Path(out).read_text().splitlines()} if Path(out).exists() else set()
    with open(out, "a") as f:
        for s in list(ds.stimuli)[start::step]:
            if s.id in done:
                continue
            ins, _ = heard(ds.root / s.audio, engine, 10)
            if ins is None:
                continue
            post = model.infer(Observation.from_scenario(scenario_for(s), ins))
            j = post.joint
            f.write(json.dumps({"id": s.id, "snr": s.snr_db, "gold": s.gold_command, "verb": scenario_for(s).verb,
                                "cmds": [str(c) for c in j.commands], "cmd_all": np.asarray(j.cmd_idx).tolist(),
                                "lj": np.asarray(j.log_joint).round(5).tolist(), "instr": rec.last.round(5).tolist()})
                    + "\n")
            f.flush()


def score(paths: list[str], gammas: list[float]) -> None:
    from siftom.bench.trials import is_correct
    from siftom.logspace import logsumexp

    for path in paths:
        rows = [json.loads(x) for x in Path(path).read_text().splitlines() if x.strip()]
        print(f"\n{path} ({len(rows)} stimuli): gamma | acc % | confident-wrong % | NLL | per band acc")
        for g in gammas:
            acc, cw, nll, band = [], [], [], {}
            for r in rows:
                ca = np.asarray(r["cmd_all"])
                instr = np.asarray(r["instr"])
                lj = np.asarray(r["lj"]) + (g - 1.0) * instr[ca]
                p = np.exp(lj - logsumexp(lj))
                pc = np.bincount(ca, weights=p, minlength=len(r["cmds"]))
                k = int(np.argmax(pc))
                ok = is_correct(r["cmds"][k], r["gold"], r["verb"])
                gold = [i for i, c in enumerate(r["cmds"]) if is_correct(c, r["gold"], r["verb"])]
                acc.append(ok)
                cw.append((not ok) and pc[k] >= 0.8)
                nll.append(-np.log(max(float(pc[gold].sum()) if gold else 0.0, 1e-6)))
                band.setdefault("clean" if r["snr"] is None else f"{r['snr']:g}", []).append(ok)
            print(f"{g:4.2f} | {100 * np.mean(acc):.1f} | {100 * np.mean(cw):.1f} | {np.mean(nll):.3f} | "
                  + " ".join(f"{b}:{100 * np.mean(v):.0f}" for b, v in sorted(band.items())))


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("what", choices=["collect", "score"])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--step", type=int, default=2)
    ap.add_argument("--gammas", default="1,0.9,0.8,0.7,0.6,0.5")
    a = ap.parse_args()
    if a.what == "collect":
        collect(a.paths[0], a.paths[1], a.start, a.step)
    else:
        score(a.paths, [float(x) for x in a.gammas.split(",")])
