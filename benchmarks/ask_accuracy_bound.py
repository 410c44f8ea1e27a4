"""How much accuracy can asking buy at <= BUDGET questions per trial? (issue 11)

From an eval results folder (with the ``siftom`` row) and the measured answer reliability
(bench/answers.py ANSWER_RELIABILITY), three ceilings on the accuracy of the executed command:

* MAP after asking, oracle-targeted: every question goes to a trial whose MAP command is wrong
  (the ones heard best first) and fixes it when its answer is heard right (the most reliable
  question kind at that SNR): accuracy <= (right + sum of the best BUDGET*N reliabilities) / N;
* MAP after asking, questions to the BUDGET*N least confident trials (what a posterior can see);
* acting for the team with the truth known: the share of trials where the team's best action
  for the true goal (the simulation's argmax over every command and doing nothing) is the gold
  command; a rule that acts by expected benefit after understanding perfectly scores no more.

    PYTHONPATH=src python benchmarks/ask_accuracy_bound.py DATASET RESULTS [--budget 0.3]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("results")
    ap.add_argument("--budget", type=float, default=0.3)
    a = ap.parse_args()
    from siftom.assist.decide import Situation
    from siftom.assist.questions import KINDS
    from siftom.assist.teamvalue import team_values
    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr
    from siftom.bench.answers import answer_reliability
    from siftom.inference.model import JointPosterior

    for t in ev._read_jsonl(Path(a.results) / ev.TEAM_CACHE):
        tr._TEAM.setdefault((t["key"], t["command"]), t)
    with open(Path(a.results) / "results.jsonl", encoding="utf-8") as f:
        rows = [json.loads(line) for line in f if line.strip()]
    n = len(rows)
    q = int(a.budget * n)
    right = sum(r["models"]["siftom"]["correct"] for r in rows)
    best_r = {}
    for r in rows:
        snr = r["snr_db"]
        best_r[r["id"]] = max(answer_reliability(snr, k) for k in KINDS)
    wrong = [r for r in rows if not r["models"]["siftom"]["correct"]]
    gains = sorted((best_r[r["id"]] for r in wrong), reverse=True)[:q]
    low = sorted(rows, key=lambda r: r["models"]["siftom"]["prob"])[:q]
    low_gain = sum(best_r[r["id"]] for r in low if not r["models"]["siftom"]["correct"])
    # the team's best action for the true goal
    from siftom.api import get_model
    from siftom.inference.model import Observation

    model = get_model("full", "phonetic")
    obey = []
    for s, sc, _r, instr in tr.saved_trials(a.dataset, a.results):
        j = model.infer(Observation.from_scenario(sc, instr)).joint
        gi = [g.name for g in j.goals].index(sc.goal.name)
        pm = JointPosterior(j.goals, j.commands, np.array([gi]), np.array([0]), np.array([0.0]), j.state)
        where = Situation.from_scenario(sc)
        tv = team_values(pm, sc.world, sc.target, where.state, where.prefix)
        best = tv.actions[int(np.argmax(tv.benefit[0]))] if tv.benefit[0].max() > 0 else "none"
        obey.append(tr.is_correct(best, s.gold_command, sc.verb))
    print(f"{a.results}: n {n}, MAP right {right} ({100 * right / n:.1f} %), wrong {len(wrong)}, "
          f"budget {q} questions")
    print(f"  MAP after asking, oracle-targeted: <= {100 * (right + sum(gains)) / n:.1f} % "
          f"(if every question were heard: {100 * (right + min(q, len(wrong))) / n:.1f} %)")
    print(f"  MAP after asking the {q} least confident trials: <= {100 * (right + low_gain) / n:.1f} % "
          f"({sum(not r['models']['siftom']['correct'] for r in low)} of the wrong ones among them)")
    print(f"  the team's best action for the true goal is the gold command in {100 * np.mean(obey):.1f} % of trials")


if __name__ == "__main__":
    main()
