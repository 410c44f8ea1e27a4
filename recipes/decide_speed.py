"""The time a decision rule adds, against the inference it follows.

For each scenario the posterior is computed from scratch (phonetic caches and per-state
cost-to-go tables cleared, as in ``siftom bench inference``), then each rule decides from
scratch (its per-state tables cleared too). The target: expected-benefit within 2x the
inference time. Numbers are wall-clock medians on one process.

    python recipes/decide_speed.py [--repeats 20] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

# (scenario, what was heard): a flat kitchen request, household requests with the count unsaid
CASES = (
    ("kitchen-cereal-v0", None),
    ("kitchen-v0/3", "could you get the oil"),
    ("household-table-v0/0", "get the bowls"),
    ("household-table-v0/3", "get the spoons"),
    ("household-table-v0/7", "we still need the glasses"),
    ("household-table-v0/12", "pass me the cutlery"),
)
RULE_NAMES = ("map", "expected-benefit", "ask-or-act")


def _median_ms(fn, n: int) -> float:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        ts.append((time.perf_counter() - t0) * 1000.0)
    return float(np.median(ts))


def run_decision_bench(repeats: int = 20) -> dict:
    """Median inference and decision times (ms) per scenario, and their ratio."""
    from siftom.assist import teamvalue
    from siftom.assist.decide import Situation, get_rule
    from siftom.bench.speed import NBEST_SILVER
    from siftom.inference.model import ModelConfig, Observation, SIFToM
    from siftom.likelihood.phonetic import PhoneticLikelihood
    from siftom.memo import memo
    from siftom.observation import Instruction
    from siftom.scenarios.base import get_scenario

    lk = PhoneticLikelihood()
    model = SIFToM(ModelConfig(), lk)
    rows = []
    for sid, words in CASES:
        sc = get_scenario(sid)
        instr = Instruction.from_nbest(NBEST_SILVER) if words is None else Instruction.from_text(words)
        obs = Observation.from_scenario(sc, instr)
        post = model.infer(obs)  # warm-up
        ctg = model.online(sc.world, sc.start, sc.goals, sc.verb).ctg
        where = Situation.from_scenario(sc)

        def infer(obs=obs, ctg=ctg) -> None:
            memo("phonetic.distances", 1).clear()
            memo("phonetic.heard", 1).clear()
            ctg.clear_state_cache()
            model.infer(obs)

        row = {"scenario": sid, "heard": words or "(kitchen 10-best)", "hypotheses": int(len(post.joint.log_joint)),
               "infer_ms": round(_median_ms(infer, repeats), 3)}
        for name in RULE_NAMES:
            rule = get_rule(name)
            rule(post, where)  # warm-up

            def run(rule=rule, post=post, where=where) -> None:
                teamvalue.clear_state_caches(where.world)
                rule(post, where)

            row[f"{name}_ms"] = round(_median_ms(run, repeats), 3)
        row["ratio"] = round(row["expected-benefit_ms"] / row["infer_ms"], 3)
        row["ratio_ask"] = round(row["ask-or-act_ms"] / row["infer_ms"], 3)
        rows.append(row)
    return {"repeats": repeats, "cases": rows, "max_ratio": max(r["ratio"] for r in rows),
            "median_ratio": float(np.median([r["ratio"] for r in rows])),
            "max_ratio_ask": max(r["ratio_ask"] for r in rows), "floor": 2.0}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Time the decision rules against the inference they follow "
                                             "(floor: expected-benefit <= 2x).")
    ap.add_argument("--repeats", type=int, default=20, help="timed calls per case (default: 20)")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    res = run_decision_bench(a.repeats)
    if a.as_json:
        print(json.dumps(res, indent=2))
        return
    print(f"{'scenario':24s} {'hyps':>5s} {'infer':>8s} {'map':>8s} {'exp-ben':>8s} {'ask':>8s} {'ratio':>6s}")
    for r in res["cases"]:
        print(f"{r['scenario']:24s} {r['hypotheses']:5d} {r['infer_ms']:7.2f}m {r['map_ms']:7.2f}m "
              f"{r['expected-benefit_ms']:7.2f}m {r['ask-or-act_ms']:7.2f}m {r['ratio']:6.2f}")
    print(f"expected-benefit / inference: median {res['median_ratio']:.2f}, max {res['max_ratio']:.2f} "
          f"(floor {res['floor']:.0f}); ask-or-act max {res['max_ratio_ask']:.2f}")


if __name__ == "__main__":
    main()
