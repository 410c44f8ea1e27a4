"""Audit expected benefit against the team simulation (issue 11).

For each trial of an eval results folder, re-infer the posterior from the saved N-best list and
compare, for the expected-benefit action and the MAP command:

(a) the expected benefit under the posterior (steps, from the cost-to-go tables),
(b) the benefit under a point mass on the truth (the scenario's goal; steps),
(c) what the team simulation records (L_single - L_team, steps, and the speedup ratio).

(b) != (c) is a mismatch between the decision's utility and the simulation.

    siftom eval --dataset /work/datasets/kitchen --workers 1 --out runs/k
    PYTHONPATH=src python benchmarks/decision_audit.py /work/datasets/kitchen runs/k --out runs/audit-kitchen.json

RESULTS must come from an eval with the same code: the team simulation's cache is read from it
(and the simulation's A* uses the cost-to-go as heuristic, so other code may plan differently).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def point_mass(joint, goal_name: str, gold_cmd: str):
    from siftom.inference.model import JointPosterior

    gi = next((k for k, g in enumerate(joint.goals) if g.name == goal_name), None)
    ci = next((k for k, c in enumerate(joint.commands) if str(c) == gold_cmd), None)
    if gi is None or ci is None:
        return None
    return JointPosterior(joint.goals, joint.commands, np.array([gi]), np.array([ci]), np.array([0.0]), joint.state)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("results")
    ap.add_argument("--out", required=True)
    ap.add_argument("--loss-aversion", type=float, default=3.0)
    ap.add_argument("--limit", type=int, default=0)
    a = ap.parse_args()
    from siftom.api import get_model
    from siftom.assist.decide import Situation, _best
    from siftom.assist.teamvalue import team_values
    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr
    from siftom.inference.model import Observation

    for t in ev._read_jsonl(Path(a.results) / ev.TEAM_CACHE):
        tr._TEAM.setdefault((t["key"], t["command"]), t)
    model = get_model("full", "phonetic")
    recs = []
    for n, (s, sc, r, instr) in enumerate(tr.saved_trials(a.dataset, a.results)):
        if a.limit and n >= a.limit:
            break
        post = model.infer(Observation.from_scenario(sc, instr))
        where = Situation.from_scenario(sc)
        tv = team_values(post.joint, sc.world, sc.target, where.state)
        eb_i = _best(tv, a.loss_aversion)[0]
        rn_i = _best(tv, 0.0)[0]
        map_i = tv.actions.index(post.command)
        e = tv.expected()
        pm = point_mass(post.joint, sc.goal.name, s.gold_command)
        tvt = team_values(pm, sc.world, sc.target, where.state) if pm is not None else None
        skey = tr.scenario_key(s)
        rec = {"id": s.id, "snr": s.snr_db, "gold": s.gold_command, "map": post.command, "eb": tv.actions[eb_i],
               "rn": tv.actions[rn_i], "kept_mass": tv.kept_mass, "p_map": float(post.commands[0][1]),
               "logged_eb": r["models"].get("siftom-eb", {}).get("command")}
        for name, i in (("eb", eb_i), ("map", map_i), ("rn", rn_i)):
            act = tv.actions[i]
            sim = tr._simulate(skey, sc, act)
            rec[name + "_post"] = float(e[i])
            rec[name + "_true"] = float(tvt.benefit[0, i]) if tvt is not None else None
            rec[name + "_sim"] = (sim["l_single"] - sim["l_team"]) if sim.get("l_team") is not None else None
            rec[name + "_speedup"] = sim.get("speedup")
            rec[name + "_lsingle"] = sim.get("l_single")
        # the best action for the truth, by the utility and by the simulation
        if tvt is not None:
            rec["best_true"] = tvt.actions[int(np.argmax(tvt.benefit[0]))]
            rec["best_true_val"] = float(tvt.benefit[0].max())
        recs.append(rec)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(recs, indent=0))
    for name in ("eb", "map", "rn"):
        d = np.array([x[name + "_true"] - x[name + "_sim"] for x in recs
                      if x[name + "_true"] is not None and x[name + "_sim"] is not None])
        print(f"{name}: n {len(d)}, utility(truth) - simulated: mean {d.mean():+.3f}, |d|>0 {np.mean(np.abs(d) > 1e-6):.3f}, "
              f"max |d| {np.abs(d).max():.1f}; mean speedup {np.mean([x[name + '_speedup'] for x in recs]):+.4f}, "
              f"neg {np.mean([x[name + '_speedup'] < -1e-9 for x in recs]):.3f}")
    print("logged eb == re-inferred eb:", np.mean([x["logged_eb"] == x["eb"] for x in recs]))


if __name__ == "__main__":
    main()
