"""Choosing the loss aversion of the decision rules on a development set (docs/decisions.md).

    python recipes/loss_aversion.py RESULTS... [--target 0.03] [--json]

reads results folders made by ``siftom eval`` on
development sets (another seed than the evaluation sets), re-infers every stimulus once from
its cached transcript, and for each loss aversion ``lam`` of a grid lets expected benefit
choose ``argmax_a E[b] - lam E[max(0, -b)]``; each chosen command goes through the team
simulation (cached, as in the evaluator). It prints negative-speedup share, mean speedup and
accuracy per ``lam`` next to ``siftom``'s (the MAP command) and, for comparison, the same
curve for the chance constraint ``P(b < 0) <= alpha`` (expected benefit among the actions
that satisfy it; doing nothing always does). It chooses the smallest ``lam`` whose negative
share is within the target on every set and says whether the mean speedup stays at least
``siftom``'s.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

LAMBDA_GRID = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0)
ALPHA_GRID = (1.0, 0.5, 0.3, 0.2, 0.1, 0.05)


def _choose_alpha(tv: Any, alpha: float) -> int:
    eb = tv.expected()
    ok = tv.loss_probability() <= alpha + 1e-12
    ok[-1] = True
    masked = np.where(ok, eb, -np.inf)
    best = int(np.argmax(masked))
    return len(eb) - 1 if masked[-1] >= masked[best] - 1e-9 else best


class _Outcome:
    """The simulated outcome of an action index for one stimulus."""

    def __init__(self, actions: Sequence[str], skey: str, sc: Any, gold: str, post: Any) -> None:
        self.actions, self.skey, self.sc, self.gold, self.post = actions, skey, sc, gold, post

    def __call__(self, i: int) -> tuple[dict[str, Any], bool, float]:
        from siftom.bench import trials as tr

        a = self.actions[i]
        t = dict(tr._simulate(self.skey, self.sc, a), command=a)
        return t, tr.is_correct(a, self.gold, self.sc.verb), 0.0 if a == "none" else self.post.prob(a)


def _summ(trials: Sequence[tuple[dict[str, Any], bool, float]]) -> dict[str, float]:
    sp = np.array([t["speedup"] for t, _c, _p in trials if t.get("speedup") is not None], dtype=float)
    return {"speedup": float(sp.mean()) if len(sp) else float("nan"),
            "neg_speedup_share": float((sp < -1e-9).mean()) if len(sp) else float("nan"),
            "accuracy": float(np.mean([c for _t, c, _p in trials])),
            "confident_wrong_share": float(np.mean([(not c) and p >= 0.8 for _t, c, p in trials])),
            "no_action": float(np.mean([t.get("command") == "none" for t, _c, _p in trials]))}


def loss_aversion_curve(results: str | Path, lambdas: Sequence[float] = LAMBDA_GRID,
                        alphas: Sequence[float] = ALPHA_GRID) -> dict[str, Any]:
    """The negative share / speedup / accuracy of expected benefit at each loss aversion."""
    from siftom import Observer, Settings
    from siftom.assist import decide as dec
    from siftom.assist.decide import Situation
    from siftom.assist.teamvalue import team_values
    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr
    from siftom.bench.choosers import instruction_from
    from siftom.bench.results_io import read_jsonl
    from siftom.inference.model import Observation
    from siftom.people.stimuli import load_dataset, scenario_for

    root = Path(results)
    run = json.loads((root / ev.RUN).read_text(encoding="utf-8"))
    ds = load_dataset(run["dataset"])
    likelihood = run["options"].get("likelihood", "phonetic")
    likelihood = "phonetic" if likelihood == "auto" else likelihood  # the decision rules' N-best likelihood
    for t in read_jsonl(root / ev.TEAM_CACHE):
        tr._TEAM.setdefault((t["key"], t["command"]), t)
    rows = {r["id"]: r for r in ev.load_results(root)}
    model = Observer(Settings.load(env={})).model("full", likelihood)
    per_l: dict[float, list[tuple[dict[str, Any], bool, float]]] = {x: [] for x in lambdas}
    per_a: dict[float, list[tuple[dict[str, Any], bool, float]]] = {x: [] for x in alphas}
    base = []
    for s in ds.stimuli:
        r = rows.get(s.id)
        if r is None:
            continue
        sc = scenario_for(s)
        skey = tr.scenario_key(s)
        heard = instruction_from(r["transcript"]["nbest"], r["transcript"].get("engine"))
        post = model.infer(Observation.from_scenario(sc, heard))
        tv = team_values(post.joint, sc.world, sc.target, Situation.from_scenario(sc).state)
        outcome = _Outcome(tv.actions, skey, sc, s.gold_command, post)
        asked = (post.command,) if post.command in tv.actions else None  # the rule weighs what was asked
        for x in lambdas:
            per_l[x].append(outcome(dec._best(tv, x, only=asked)[0]))  # the rule's own choice
        for x in alphas:
            per_a[x].append(outcome(_choose_alpha(tv, x)))
        m = tr._simulate(skey, sc, post.command)
        base.append((dict(m, command=post.command), tr.is_correct(post.command, s.gold_command, sc.verb),
                     float(post.commands[0][1])))
    return {"results": str(root), "n": len(base), "siftom": _summ(base),
            "loss_aversion": [{"lam": x, **_summ(v)} for x, v in per_l.items()],
            "chance_constraint": [{"alpha": x, **_summ(v)} for x, v in per_a.items()]}


def choose(results: Sequence[str | Path], target: float = 0.03) -> dict[str, Any]:
    """The smallest loss aversion whose negative-speedup share is within ``target`` on every set
    (the risk a teammate accepts), whether the mean speedup then stays at least siftom's (the MAP
    command) on every set, and the curves. None when no value of the grid reaches ``target``."""
    curves = [loss_aversion_curve(r) for r in results]
    lams = [row["lam"] for row in curves[0]["loss_aversion"]]

    def keeps(k: int) -> bool:
        return all(c["loss_aversion"][k]["speedup"] >= c["siftom"]["speedup"] for c in curves)

    def worst(k: int) -> float:
        return max(c["loss_aversion"][k]["neg_speedup_share"] for c in curves)

    ok = [k for k in range(len(lams)) if worst(k) <= target]
    return {"target": target, "loss_aversion": lams[ok[0]] if ok else None,
            "speedup_kept": bool(ok) and keeps(ok[0]), "curves": curves}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Choose the loss aversion of expected benefit from development "
                                             "RESULTS folders (siftom eval).")
    ap.add_argument("results", nargs="+", help="results folders of siftom eval on development sets")
    ap.add_argument("--target", type=float, default=0.03, help="negative-speedup share allowed (default: 0.03)")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    for r in a.results:
        if not Path(r).is_dir():
            ap.error(f"{r}: no such folder")
    res = choose(a.results, a.target)
    if a.as_json:
        print(json.dumps(res, indent=2))
        return
    for c in res["curves"]:
        b = c["siftom"]
        print(f"{c['results']} (n = {c['n']}); siftom: speedup {b['speedup']:+.3f}, "
              f"negative {100 * b['neg_speedup_share']:.1f} %, accuracy {100 * b['accuracy']:.1f} %")
        for key, name in (("loss_aversion", "lam"), ("chance_constraint", "alpha")):
            for row in c[key]:
                print(f"  {name} {row[name]:5.2f}: speedup {row['speedup']:+.3f}, negative "
                      f"{100 * row['neg_speedup_share']:.1f} %, accuracy {100 * row['accuracy']:.1f} %, "
                      f"does nothing {100 * row['no_action']:.1f} %, "
                      f"confident wrong {100 * row['confident_wrong_share']:.1f} %")
    kept = "keeps" if res["speedup_kept"] else "does not keep"
    print(f"smallest loss aversion with <= {100 * res['target']:g} % negative on every set: {res['loss_aversion']} "
          f"({kept} a mean speedup >= siftom's on every set)")


if __name__ == "__main__":
    main()
