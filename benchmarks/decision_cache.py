"""Per-trial decision cache for offline studies of expected benefit (issue 11).

For each trial of an eval results folder: the posterior's terms per (goal, robot part) row
(``lj0`` = prior + actions, ``instr`` = the instruction log-likelihood), the benefit of every
action under every row (steps), V_h(now; g) per row, the observed prefix, and the truth. The
speedup of any action is simulated on demand (cached in the results folder's team cache).

    PYTHONPATH=src python benchmarks/decision_cache.py DATASET RESULTS OUT.pkl
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np


def build(dataset: str, results: str) -> list[dict]:
    from siftom.api import get_model
    from siftom.assist import teamvalue
    from siftom.assist.decide import Situation
    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr
    from siftom.inference.model import ModelConfig, Observation, SIFToM
    from siftom.world.model import cost as action_cost

    cache = Path(results) / ev.TEAM_CACHE
    if cache.exists():
        for t in ev._read_jsonl(cache):
            tr._TEAM.setdefault((t["key"], t["command"]), t)
    m1 = get_model("full", "phonetic")
    m0 = SIFToM(ModelConfig(speech_weight=0.0), m1.likelihood)
    teamvalue.KEEP_MASS, teamvalue.MAX_ROWS = 2.0, 10**9
    out = []
    for s, sc, r, instr in tr.saved_trials(dataset, results):
        obs = Observation.from_scenario(sc, instr)
        p1 = m1.infer(obs)
        p0 = m0.infer(obs)
        j = p1.joint
        flat = type(j)(j.goals, j.commands, j.goal_idx, j.cmd_idx, np.zeros(len(j.log_joint)), j.state)
        states = sc.states()
        prefix = float(sum(action_cost(sc.world, st, a) for st, a in zip(states, sc.actions, strict=False)))
        where = Situation.from_scenario(sc)
        tv = teamvalue.team_values(flat, sc.world, sc.target, where.state, prefix)
        assert len(tv.prob) == len(j.log_joint)
        out.append({"id": s.id, "snr": s.snr_db, "noise": s.noise, "gold": s.gold_command, "verb": sc.verb,
                    "skey": tr.scenario_key(s), "scenario": s.scenario, "actions": tv.actions,
                    "lj0": p0.joint.log_joint, "instr": j.log_joint - p0.joint.log_joint,
                    "cmd_idx": j.cmd_idx, "goal_idx": j.goal_idx, "commands": [str(c) for c in j.commands],
                    "benefit": tv.benefit.astype(np.float32), "single": tv.single, "prefix": prefix,
                    "logged": {k: v.get("command") for k, v in r["models"].items()}})
    return out


if __name__ == "__main__":
    recs = build(sys.argv[1], sys.argv[2])
    Path(sys.argv[3]).parent.mkdir(parents=True, exist_ok=True)
    with open(sys.argv[3], "wb") as f:
        pickle.dump(recs, f)
    print(len(recs), "trials")
