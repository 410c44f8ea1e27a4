"""``siftom bench decide``: the time a decision rule adds, against the inference it follows.

For each scenario the posterior is computed from scratch (phonetic caches and per-state
cost-to-go tables cleared, as in ``siftom bench inference``), then each rule decides from
scratch (its per-state tables cleared too). The target: expected-benefit within 2x the
inference time. Numbers are wall-clock medians on one process.
"""

from __future__ import annotations

import json
import time

import click
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
            lk._dist.clear()
            lk._heard_cache.clear()
            ctg.clear_state_cache()
            model.infer(obs)

        row = {"scenario": sid, "heard": words or "(kitchen 10-best)", "hypotheses": int(len(post.joint.log_joint)),
               "infer_ms": round(_median_ms(infer, repeats), 3)}
        for name in RULE_NAMES:
            rule = get_rule(name)
            rule(post, where)  # warm-up

            def run(rule=rule, post=post, where=where) -> None:
                for per in teamvalue._CTG.get(where.world, {}).values():
                    per.clear_state_cache()
                rule(post, where)

            row[f"{name}_ms"] = round(_median_ms(run, repeats), 3)
        row["ratio"] = round(row["expected-benefit_ms"] / row["infer_ms"], 3)
        row["ratio_ask"] = round(row["ask-or-act_ms"] / row["infer_ms"], 3)
        rows.append(row)
    return {"repeats": repeats, "cases": rows, "max_ratio": max(r["ratio"] for r in rows),
            "median_ratio": float(np.median([r["ratio"] for r in rows])),
            "max_ratio_ask": max(r["ratio_ask"] for r in rows), "floor": 2.0}


@click.command("decide")
@click.option("--repeats", type=int, default=20, show_default=True, help="timed calls per case")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def bench_decide_cmd(repeats: int, as_json: bool) -> None:
    """Time the decision rules against the inference they follow (floor: expected-benefit <= 2x)."""
    res = run_decision_bench(repeats)
    if as_json:
        click.echo(json.dumps(res, indent=2))
        return
    click.echo(f"{'scenario':24s} {'hyps':>5s} {'infer':>8s} {'map':>8s} {'exp-ben':>8s} {'ask':>8s} {'ratio':>6s}")
    for r in res["cases"]:
        click.echo(f"{r['scenario']:24s} {r['hypotheses']:5d} {r['infer_ms']:7.2f}m {r['map_ms']:7.2f}m "
                   f"{r['expected-benefit_ms']:7.2f}m {r['ask-or-act_ms']:7.2f}m {r['ratio']:6.2f}")
    click.echo(f"expected-benefit / inference: median {res['median_ratio']:.2f}, max {res['max_ratio']:.2f} "
               f"(floor {res['floor']:.0f}); ask-or-act max {res['max_ratio_ask']:.2f}")
