"""Where counts go wrong: per stimulus of a household dataset, what was said and heard about the count.

    python recipes/count_diagnostics.py DATASET OUT.jsonl [--start 0 --step 1] [--limit N]

Per stimulus: the reference, whether it says a count word and where (before the object, after
it, elsewhere), whether pocketsphinx's 1-best and Whisper's own transcript hold the count word
and the object word, the default path's choice and probability, and the actions-alone posterior
of the gold command. ``--summary OUT.jsonl`` prints the tables by SNR.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

COUNTS = {"one": 1, "two": 2, "three": 3, "four": 4, "1": 1, "2": 2, "3": 3, "4": 4}


def count_words(words: list[str]) -> list[int]:
    return [COUNTS[w] for w in words if w in COUNTS]


class _Recorded:
    """The acoustic likelihood with the count tie off, remembering its last scores."""

    uses_context = True
    name = "acoustic-untied"

    def __init__(self) -> None:
        from siftom.likelihood.acoustic import AcousticLikelihood

        self.inner = AcousticLikelihood(tie_counts=False)
        self.last = None

    def log_prob(self, instruction, commands, context=None):
        scores = self.inner.log_prob(instruction, commands, context=context)
        self.last = np.asarray(scores.log_probs, dtype=float)
        # the recogniser's 1-best and Whisper's own words (the evidence says them; "" without Whisper)
        self.heard = [instruction.text, str(scores.evidence.get("whisper_heard", "")).split()]
        return scores

    def evidence(self):
        return self.inner.evidence()


class _Tied:
    """The same scores with the counts nobody heard tied (``likelihood.counts``)."""

    name = "acoustic-tied"

    def __init__(self, rec: _Recorded) -> None:
        self.rec = rec

    def log_prob(self, instruction, commands):
        from siftom.likelihood.counts import count_heard, tie_unheard_counts

        out = self.rec.last
        return out if count_heard(self.rec.heard) else tie_unheard_counts(out, commands)


def run(dataset: str, out: str, start: int, step: int, limit: int | None) -> None:
    from siftom import Observer, Settings
    from siftom.bench.acoustic_models import heard
    from siftom.bench.trials import dataset_vocabulary
    from siftom.inference.model import ModelConfig, Observation, SIFToM
    from siftom.likelihood.counts import count_heard
    from siftom.people.stimuli import load_dataset, scenario_for
    from siftom.speech.asr.base import get_engine
    from siftom.world.commands import RobotCommand

    ds = load_dataset(dataset)
    stimuli = list(ds.stimuli)[start::step][:limit]
    engine = get_engine("pocketsphinx-vocab", vocabulary=dataset_vocabulary(ds.stimuli))
    done = set()
    if Path(out).exists():
        done = {json.loads(x)["id"] for x in Path(out).read_text().splitlines() if x.strip()}
    rec = _Recorded()
    full, tied = SIFToM(ModelConfig("full"), rec), SIFToM(ModelConfig("full"), _Tied(rec))
    action = Observer(Settings.load(env={})).model("action-only", "phonetic")
    with open(out, "a") as f:
        for s in stimuli:
            if s.id in done:
                continue
            sc = scenario_for(s)
            instruction, _ = heard(ds.root / s.audio, engine, 10)
            gold = RobotCommand.parse(s.gold_command)
            ap = action.infer(Observation.from_scenario(sc, None))
            row = {"id": s.id, "snr": s.snr_db, "reference": s.reference, "gold": s.gold_command,
                   "action_top": ap.command, "action_p_gold": round(ap.prob(s.gold_command), 4),
                   "action_p_top": round(ap.commands[0][1], 4)}
            if instruction is None:
                row.update(heard="", whisper="", chosen=ap.command, p=ap.commands[0][1],
                           tied=ap.command, p_tied=ap.commands[0][1], count_heard=False)
            else:
                obs = Observation.from_scenario(sc, instruction)
                post = full.infer(obs)
                pt = tied.infer(obs)
                row.update(heard=instruction.text, whisper=" ".join(rec.heard[1]),
                           chosen=post.command, p=round(post.commands[0][1], 4),
                           tied=pt.command, p_tied=round(pt.commands[0][1], 4), count_heard=count_heard(rec.heard),
                           top=[(c, round(p, 3)) for c, p in post.commands[:4]],
                           top_tied=[(c, round(p, 3)) for c, p in pt.commands[:4]])
            row["gold_class"], row["gold_count"] = gold.obj_class, gold.count
            f.write(json.dumps(row) + "\n")
            f.flush()


KEY, PKEY = "chosen", "p"


def summary(path: str) -> None:
    from siftom.world.commands import RobotCommand

    rows = [json.loads(x) for x in Path(path).read_text().splitlines() if x.strip()]
    by = defaultdict(lambda: defaultdict(int))
    for r in rows:
        b = "clean" if r["snr"] is None else f"{r['snr']:g}"
        ref = r["reference"].split()
        said = count_words(ref)
        c = RobotCommand.parse(r[KEY]) if r[KEY] != "none" else None
        cls_ok = c is not None and c.obj_class == r["gold_class"]
        cnt_ok = c is not None and c.count == r["gold_count"]
        d = by[b]
        d["n"] += 1
        d["count said"] += bool(said)
        for src in ("heard", "whisper"):
            hw = r[src].split()
            if said:
                d[f"{src}: count lost"] += not count_words(hw)
                d[f"{src}: count wrong"] += bool(count_words(hw)) and said[0] not in count_words(hw)
        d["class right"] += cls_ok
        d["class right, count wrong"] += cls_ok and not cnt_ok
        d["class right, count wrong, count said"] += cls_ok and not cnt_ok and bool(said)
        d["confident wrong"] += (not (cls_ok and cnt_ok)) and r[PKEY] >= 0.8
        d["confident wrong: count only"] += cls_ok and not cnt_ok and r[PKEY] >= 0.8
        d["correct"] += cls_ok and cnt_ok
    keys = sorted({k for d in by.values() for k in d})
    bands = [b for b in ("clean", "20", "10", "5") if b in by]
    print("| | " + " | ".join(bands) + " |")
    print("|---|" + "---|" * len(bands))
    for k in keys:
        print(f"| {k} | " + " | ".join(str(by[b][k]) for b in bands) + " |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset", nargs="?")
    ap.add_argument("out")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--summary", action="store_true")
    a = ap.parse_args()
    if a.summary:
        summary(a.out)
        KEY, PKEY = "tied", "p_tied"
        print("\ncounts nobody heard tied:")
        summary(a.out)
        sys.exit(0)
    run(a.dataset, a.out, a.start, a.step, a.limit)
