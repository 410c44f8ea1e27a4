"""Decision-rule models in the benchmark: ``siftom-eb`` (expected benefit) and ``siftom-ask``.

``siftom-ask`` may ask a clarifying question (assist/questions.py: confirm, choose, count).
The simulated human answers truthfully about its command (the gold command) with a phrase of
the question's answer grammar, in the stimulus's voice, mixed with the stimulus's noise type at
its SNR; the evaluator's ASR engine listens with that grammar (bench/answers.py), so a
question can fail. The heard cell updates the posterior through the kind's measured channel.
Every random choice (phrase, noise excerpt) is seeded from the stimulus id, so runs are
deterministic. The robot then acts by expected benefit on the updated posterior; the exchange
costs the team ``ask_cost`` steps (added to L_team).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from typing import Any

import click
import numpy as np

from siftom.assist.decide import (
    DEFAULT_ASK_COST,
    DEFAULT_LOSS_AVERSION,
    DEFAULT_QUESTION_PENALTY,
    Situation,
    decide,
    with_answer,
)
from siftom.assist.questions import answer_log_likelihood_cells
from siftom.bench import answers as _answers

DECISION_MODELS = {"siftom-eb": "expected-benefit", "siftom-ask": "ask-or-act"}
# the measured reliability table and the answer path live in bench/answers.py
ANSWER_RELIABILITY = _answers.ANSWER_RELIABILITY
answer_reliability = _answers.answer_reliability


def _env_float(name: str, default: float) -> float:
    v = os.environ.get(name)
    return float(v) if v else default


def run_decision_model(
    model: str,
    stimulus: Any,
    scenario: Any,
    instruction: Any,
    likelihood: str,
    dataset_root: str,
    transcribe: Callable[..., Any],
    ask_cost: float = DEFAULT_ASK_COST,
    penalty: float | None = None,
) -> dict[str, Any]:
    """Decide for one stimulus; returns command, prob and what was asked and heard.

    Args:
        model: ``siftom-eb`` or ``siftom-ask``.
        stimulus: the dataset stimulus.
        scenario: its scenario.
        instruction: what was heard (the N-best list), or None.
        likelihood: the instruction likelihood's name (it also scores the answer).
        dataset_root: the dataset folder (for its noise folder).
        transcribe: ``(audio samples, grammar phrases) -> transcript`` with ``nbest``: the
            evaluator's ASR engine listening for the question's answers (bench/answers.py).
        ask_cost: steps one question costs the team (added to L_team).
        penalty: the interruption penalty in steps (default: ``$SIFTOM_QUESTION_PENALTY``, for
            tuning runs on a development set, else :data:`DEFAULT_QUESTION_PENALTY`).
    """
    from siftom.api import get_model
    from siftom.bench.trials import is_correct
    from siftom.inference.model import Observation

    if penalty is None:
        penalty = _env_float("SIFTOM_QUESTION_PENALTY", DEFAULT_QUESTION_PENALTY)
    lam = _env_float("SIFTOM_LOSS_AVERSION", DEFAULT_LOSS_AVERSION)
    sift = get_model("full", likelihood)
    posterior = sift.infer(Observation.from_scenario(scenario, instruction))
    reliability = _answers.answer_reliabilities(stimulus.snr_db)
    where = Situation.from_scenario(scenario, answer_reliability=reliability)
    rule = DECISION_MODELS[model]
    opts: dict[str, float] = {"loss_aversion": lam}
    if rule == "ask-or-act":
        opts.update(ask_cost=ask_cost, penalty=penalty)
    d = decide(posterior, where, rule, **opts)
    # what the robot believes was asked for (the MAP command), next to what it does
    out: dict[str, Any] = {"command": d.command, "prob": d.prob, "asked": False,
                           "expected_benefit": round(d.expected_benefit, 3), "map_command": posterior.command,
                           "map_correct": is_correct(posterior.command, stimulus.gold_command, scenario.verb)}
    if rule == "ask-or-act":
        out.update({"evi": round(d.evi, 3), "ask_cost": ask_cost, "penalty": penalty,
                    "answer_reliability": {k: round(v, 4) for k, v in reliability.items()}})
    if not d.ask:
        return out
    q = d.asked
    if q is None:  # an ask decision always carries its question
        return out
    cell = next((k for k, o in enumerate(q.options) if is_correct(o, stimulus.gold_command, scenario.verb)),
                q.n_cells - 1)
    h = _answers.ask_and_hear(q, cell, stimulus, dataset_root, transcribe)
    r = where.reliability(q.kind)
    ll = answer_log_likelihood_cells(q, [str(c) for c in posterior.joint.commands], h["heard_cell"], r)
    post2 = with_answer(posterior, ll, h["answer_heard"])
    # the question's time is spent: it counts in every outcome after the answer, as the EVI assumed
    d2 = decide(post2, where, "expected-benefit", loss_aversion=lam, spent=ask_cost)
    out.update({"command": d2.command, "prob": d2.prob, "asked": True, "question": d.question,
                "question_kind": q.kind, "evi": round(d.evi, 3), "ask_cost": ask_cost, "command_before": d.command,
                "correct_before": is_correct(d.command, stimulus.gold_command, scenario.verb),
                "answer": h["answer"], "answer_heard": h["answer_heard"], "map_command": post2.command,
                "answer_cell_ok": h["heard_cell"] == cell, "answer_unclear": h["heard_cell"] is None,
                "map_correct": is_correct(post2.command, stimulus.gold_command, scenario.verb),
                "expected_benefit": round(d2.expected_benefit, 3)})
    return out


def decision_fields(extra: dict[str, Any], team: dict[str, Any]) -> dict[str, Any]:
    """Fields a decision model adds to its results entry; a question's cost is added to L_team."""
    out = dict(extra)
    if extra.get("asked") and team.get("l_team") is not None:
        l_team = team["l_team"] + float(extra.get("ask_cost", DEFAULT_ASK_COST))
        out["l_team"] = l_team
        out["speedup"] = round(team["l_single"] / l_team - 1.0, 6) if l_team > 0 else 0.0
    return out


def penalty_curve(rows: list[dict[str, Any]], penalties: Any) -> list[dict[str, float]]:
    """Questions, accuracy and speedup of ``siftom-ask`` at each interruption penalty.

    ``rows`` come from a tuning run with the penalty at 0 (``SIFTOM_QUESTION_PENALTY=0``) and
    both ``siftom-eb`` and ``siftom-ask``: a trial asks at penalty ``x`` iff its EVI exceeds
    ``ask_cost + x``; then its outcome is the asking model's, otherwise the expected-benefit one's.
    """
    out = []
    for x in penalties:
        res = []
        for r in rows:
            if "siftom-ask" not in r["models"] or "siftom-eb" not in r["models"]:
                continue  # not evaluable for one of them (its answer could not be synthesised)
            a, e = r["models"]["siftom-ask"], r["models"]["siftom-eb"]
            if a.get("penalty", 0.0) != 0.0:
                raise ValueError("tune on a run made with SIFTOM_QUESTION_PENALTY=0")
            res.append((True, a) if a.get("asked") and a["evi"] > a["ask_cost"] + x else (False, e))
        sp = np.array([t["speedup"] for _, t in res if t.get("speedup") is not None], dtype=float)
        out.append({"penalty": float(x), "questions_per_trial": float(np.mean([q for q, _ in res])),
                    "accuracy": float(np.mean([t["correct"] for _, t in res])),
                    "speedup": float(sp.mean()) if len(sp) else float("nan"),
                    "neg_speedup_share": float((sp < -1e-9).mean()) if len(sp) else float("nan")})
    return out


@click.command("ask-penalty")
@click.argument("results", nargs=-1, required=True, type=click.Path(file_okay=False))
@click.option("--budget", type=float, default=0.3, show_default=True, help="questions per trial allowed")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def ask_penalty_cmd(results: tuple[str, ...], budget: float, as_json: bool) -> None:
    """Choose the interruption penalty from development runs made with SIFTOM_QUESTION_PENALTY=0.

    The smallest penalty (steps, on a 0.5 grid) whose questions per trial stay within BUDGET
    on every RESULTS folder: the Lagrange multiplier of the question budget.
    """
    from siftom.bench.evaluate import load_results

    grid = np.arange(0.0, 40.01, 0.5)
    curves = {r: penalty_curve(load_results(r), grid) for r in results}
    ok = [x for k, x in enumerate(grid) if all(c[k]["questions_per_trial"] <= budget for c in curves.values())]
    chosen = float(ok[0]) if ok else None
    if as_json:
        click.echo(json.dumps({"budget": budget, "penalty": chosen, "curves": curves}, indent=2))
        return
    for r, c in curves.items():
        click.echo(r)
        for row in c[::4]:
            click.echo(f"  penalty {row['penalty']:5.1f}: {row['questions_per_trial']:.3f} questions/trial, "
                       f"accuracy {100 * row['accuracy']:.1f} %, speedup {row['speedup']:+.3f}, "
                       f"negative {100 * row['neg_speedup_share']:.1f} %")
    click.echo(f"smallest penalty within {budget} questions per trial on every set: {chosen}")


def reliability_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """How often ``siftom-ask``'s answers were heard as the cell they name, by SNR (clean last)."""
    by: dict[float, list[bool]] = {}
    for r in rows:
        a = r["models"].get("siftom-ask", {})
        if a.get("asked") and "answer_cell_ok" in a:
            snr = float("inf") if r.get("snr_db") is None else float(r["snr_db"])
            by.setdefault(snr, []).append(bool(a["answer_cell_ok"]))
    return [{"snr_db": k, "n": len(v), "heard": float(np.mean(v))} for k, v in sorted(by.items())]


@click.command("answer-reliability")
@click.argument("results", nargs=-1, required=True, type=click.Path(file_okay=False))
def answer_reliability_cmd(results: tuple[str, ...]) -> None:
    """How often answers to siftom-ask's questions were heard right, by SNR, pooled over RESULTS.

    Measure on development runs made with SIFTOM_QUESTION_PENALTY=0 SIFTOM_ANSWER_RELIABILITY=1
    (every question worth its time is asked and the EVI is unweighted); the printed table is
    ANSWER_RELIABILITY in bench/decisions.py.
    """
    from siftom.bench.evaluate import load_results

    rows = [r for res in results for r in load_results(res)]
    table = reliability_table(rows)
    for t in table:
        snr = "clean" if not np.isfinite(t["snr_db"]) else f"{t['snr_db']:g} dB"
        click.echo(f"  {snr:>6}: {t['n']:4d} answers, heard as the cell they name {100 * t['heard']:.1f} %")
    inf = 'float("inf")'
    pts = [f"({t['snr_db'] if np.isfinite(t['snr_db']) else inf}, {t['heard']:.2f})" for t in table]
    click.echo("ANSWER_RELIABILITY = (" + ", ".join(pts) + ")")
