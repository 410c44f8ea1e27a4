"""Decision models in the benchmark: every decision rule on every instruction likelihood.

A decision model is a likelihood (the posterior) composed with a decision rule (what the
robot does with it), registered in bench/models.py: ``siftom-eb`` is expected benefit on the
default (acoustic) likelihood and ``siftom-phonetic-ask`` ask-or-act on the phonetic one
(docs/decisions.md). The MAP rule's rows
are the evaluator's own ``siftom`` models.

An asking model may ask a clarifying question (assist/questions.py: confirm, choose, count).
The simulated human answers truthfully about its command (the gold command) with a phrase of
the question's answer grammar, in the stimulus's voice, mixed with the stimulus's noise type at
its SNR; the evaluator's ASR engine listens with that grammar (bench/answers.py), so a
question can fail. The heard cell updates the posterior through the kind's measured channel.
Every random choice (phrase, noise excerpt) is seeded from the stimulus id, so runs are
deterministic. The robot then acts by expected benefit on the updated posterior; the exchange
costs the team its spoken time (assist/askcost.py), added to L_team.

The goal-known oracle (:func:`oracle_action`) is the best action for the true goal, which the
report's regret is measured against.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import numpy as np

from siftom.assist.askcost import QuestionCost
from siftom.assist.decide import (
    DEFAULT_LOSS_AVERSION,
    Situation,
    get_rule,
)
from siftom.assist.questions import (  # noqa: F401  (the table and its reader, named here for the benchmark)
    ANSWER_RELIABILITY,
    answer_reliability,
)
from siftom.bench import answers as _answers
from siftom.bench.models import decision_models

DEFAULT_DECISION_LIKELIHOOD = "acoustic"
MAX_QUESTIONS = 3  # the most questions the simulated exchange answers about one request (then: as it stands)
# the measured reliability table lives in assist/questions.py, the answer path in bench/answers.py


def decision_posterior(likelihood: str, scenario: Any, instruction: Any, audio: Path, engine: Any,
                       nbest: int) -> Any:
    """The full model's posterior for a stimulus under ``likelihood``, from the evaluator's observer.

    ``phonetic`` scores the evaluator's N-best list (``instruction``); ``acoustic`` hears the
    clip as ``siftom-acoustic`` does (bench/acoustic_models.py); a clip with no words heard
    gets the posterior of the actions alone.
    """
    from siftom.bench.models import eval_settings
    from siftom.observer import observer_for

    obs = observer_for(eval_settings("full"))
    if likelihood == "acoustic":
        from siftom.bench.acoustic_models import heard

        instruction, _ = heard(audio, engine, nbest)
        if instruction is None:
            return obs.infer(scenario, None, None, mode="action-only", decide="map", gate=False).posterior
    return obs.infer(scenario, None, instruction, likelihood=likelihood, decide="map", gate=False).posterior


def oracle_action(scenario: Any, gold_command: str) -> str:
    """The best action for the true goal (goal known): argmax of the steps saved, ties to nothing.

    The team values of every command of the domain (and of doing nothing) under a point mass on
    the scenario's goal, with the gold command as what was asked (assist/teamvalue.py; they equal
    the team simulation's, docs/decisions.md).
    """
    from siftom.assist.teamvalue import NONE, team_values
    from siftom.bench.llm_baselines import command_space
    from siftom.inference.model import JointPosterior
    from siftom.world.commands import RobotCommand

    cmds = command_space(scenario)
    gold = RobotCommand.parse(gold_command)
    if gold not in cmds:
        cmds.append(gold)
    where = Situation.from_scenario(scenario)
    joint = JointPosterior((scenario.goal,), tuple(cmds), np.array([0]), np.array([cmds.index(gold)]),
                           np.array([0.0]), where.state)
    tv = team_values(joint, scenario.world, scenario.target, where.state, where.prefix)
    b = tv.benefit[0]
    best = int(np.argmax(b))
    return NONE if b[-1] >= b[best] - 1e-9 else tv.actions[best]


def decision_heard(likelihood: str, instruction: Any, audio: Path, engine: Any, nbest: int) -> Any:
    """What a decision model hears: the evaluator's N-best (``phonetic``) or the clip as
    ``siftom-acoustic`` hears it (``acoustic``; None when no words were heard)."""
    if likelihood == "acoustic":
        from siftom.bench.acoustic_models import heard

        return heard(audio, engine, nbest)[0]
    return instruction


def run_decision_model(
    model: str,
    stimulus: Any,
    scenario: Any,
    instruction: Any,
    dataset_root: str,
    transcribe: Callable[..., Any],
    cost_model: QuestionCost | None = None,
    ask_cost: float | None = None,
) -> dict[str, Any]:
    """Decide for one stimulus through the observer, as the doors do; returns command, prob and
    what was asked and heard.

    The model's rule answers through :meth:`siftom.Observer.answer` (nobody asked: nothing;
    an absent object: declined with its reason; several parts: the first carried out), with the
    measured answer reliability at the stimulus's SNR. When it asks, the simulated person's
    spoken answer is heard with the question's grammar and goes back through the same observer
    as the reply to the pending question (assist/reply.py); a second question is not answered
    (the robot does nothing in that trial).

    Args:
        model: a decision model's name (``bench/models.py``).
        stimulus: the dataset stimulus.
        scenario: its scenario.
        instruction: what the model heard (:func:`decision_heard`; None: no words).
        dataset_root: the dataset folder (for its noise folder).
        transcribe: ``(audio samples, grammar phrases) -> transcript`` with ``nbest``: the
            evaluator's ASR engine listening for the question's answers (bench/answers.py).
        cost_model: the time model of a spoken exchange (default :class:`QuestionCost`).
        ask_cost: a fixed time per question in steps instead of the model (None: the model).
    """
    from siftom.bench.models import eval_settings
    from siftom.bench.scoring import is_correct
    from siftom.inputs import resolve_scene
    from siftom.observer import observer_for

    lk, rule = decision_models()[model]
    cm = cost_model or QuestionCost()
    reliability = _answers.answer_reliabilities(stimulus.snr_db)
    chooser = _rule(rule, cm, ask_cost)
    obs = observer_for(eval_settings("full"))
    online = obs.online(resolve_scene(scenario, None), "full")
    ans = obs.answer(online, instruction, likelihood=lk, decide=chooser, answer_reliability=reliability)
    d = ans.decision

    top = str(ans.top_command)
    command, prob = (d.command, ans.prob(d.command)) if d.ask else _done(ans)
    out: dict[str, Any] = {"command": command, "prob": prob, "asked": False, "action": ans.action,
                           "reason": d.reason, "declined": d.declined, "expected_benefit": _benefit(ans),
                           "map_command": top, "map_correct": is_correct(top, stimulus.gold_command, scenario.verb)}
    if rule in ("ask-or-act", "teammate"):
        out.update({"evi": round(d.evi, 3), "question_cost": round(d.ask_cost, 3),
                    "answer_reliability": {k: round(v, 4) for k, v in reliability.items()}})
    if not d.ask or d.asked is None:
        return out
    h0, spent, said, now = _exchange(
        ans, stimulus, scenario, dataset_root, transcribe,
        lambda reply, pending: obs.answer(online, reply, likelihood="phonetic", decide=chooser, pending=pending,
                                          answer_reliability=reliability),
        lambda q, h: float(ask_cost) if ask_cost is not None else cm.steps(q.text, h.answer))
    if h0 is None:  # (the loop runs at least once: the first answer asked)
        return out
    top2 = str(now.top_command)
    command, prob = _done(now)
    first_cell = h0.cell
    out.update({"command": command, "prob": prob, "asked": True, "question": d.question,
                "question_kind": d.asked.kind, "questions": len(said), "exchange": said,
                "ask_cost": round(spent, 4), "command_before": d.command, "action_after": now.action,
                "asked_again": len(said) > 1 or now.action == "ask",
                "correct_before": is_correct(d.command, stimulus.gold_command, scenario.verb),
                "answer": h0.answer, "answer_heard": h0.answer_heard, "map_command": top2,
                **({"answer_cell_ok": h0.heard_cell == first_cell, "answer_unclear": h0.heard_cell is None}
                   if first_cell is not None else {}),
                "map_correct": is_correct(top2, stimulus.gold_command, scenario.verb),
                "expected_benefit": _benefit(now)})
    return out


def _rule(rule: str, cm: QuestionCost, ask_cost: float | None) -> Any:
    """The decision rule ``rule`` as the benchmark runs it (an asking rule with the exchange's cost)."""
    opts: dict[str, Any] = {"loss_aversion": DEFAULT_LOSS_AVERSION}
    if rule in ("ask-or-act", "teammate"):
        opts.update(ask_cost=ask_cost, cost_model=cm)
    return get_rule(rule, **opts)


def _done(a: Any) -> tuple[str, float]:
    """(the command carried out or "none", its probability)."""
    if a.action != "act" or not a.carry_out:
        return "none", 0.0
    return str(a.carry_out[0]), float(a.prob(str(a.carry_out[0])))


def _benefit(a: Any) -> float | None:
    eb = float(a.decision.expected_benefit)
    return round(eb, 3) if np.isfinite(eb) else None


def _exchange(ans: Any, stimulus: Any, scenario: Any, dataset_root: str, transcribe: Callable[..., Any],
              heard_as: Callable[[Any, Any], Any], cost: Callable[[Any, _answers.HeardAnswer], float],
              ) -> tuple[_answers.HeardAnswer | None, float, list[str], Any]:
    """The spoken exchange after a question: the person answers each question and the robot may
    ask again (up to :data:`MAX_QUESTIONS`); (the first answer heard, the time spent, what was
    asked and heard, the last answer)."""
    from siftom.bench.scoring import is_correct
    from siftom.observation import Instruction

    h0, spent, now = None, 0.0, ans
    said: list[str] = []
    while now.action == "ask" and now.decision.asked is not None and len(said) < MAX_QUESTIONS:
        q = now.decision.asked
        if q.kind == "open":  # "Sorry, what do you need?": the person says the request again
            h = _answers.repeat_and_hear(stimulus, dataset_root, transcribe, salt=len(said))
        else:
            cell = next((k for k, o in enumerate(q.options) if is_correct(o, stimulus.gold_command, scenario.verb)),
                        q.n_cells - 1)
            h = _answers.ask_and_hear(q, cell, stimulus, dataset_root, transcribe, salt=len(said))
        h0 = h0 or h
        spent += cost(q, h)
        said.append(f"{q.text} -> {h.answer_heard}")
        reply = Instruction.from_text(h.answer_heard) if str(h.answer_heard).strip() else None
        now = heard_as(reply, now.pending)
    return h0, spent, said, now


def reliability_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """How often the asking models' answers were heard as the cell they name, by SNR (clean last)."""
    by: dict[float, list[bool]] = {}
    asking = [m for m, (_lk, rule) in decision_models().items() if rule == "ask-or-act"]
    for r in rows:
        for a in (r["models"].get(m, {}) for m in asking):
            if not (a.get("asked") and "answer_cell_ok" in a):
                continue
            snr = float("inf") if r.get("snr_db") is None else float(r["snr_db"])
            by.setdefault(snr, []).append(bool(a["answer_cell_ok"]))
    return [{"snr_db": k, "n": len(v), "heard": float(np.mean(v))} for k, v in sorted(by.items())]


@click.command("answer-reliability")
@click.argument("results", nargs=-1, required=True, type=click.Path(file_okay=False))
def answer_reliability_cmd(results: tuple[str, ...]) -> None:
    """How often answers to the asking models' questions were heard right, by SNR, pooled over RESULTS.

    What the evaluation's questions met (the table the robot uses is measured by
    ``siftom bench answer-grammar`` on a development set: ANSWER_RELIABILITY in assist/questions.py).
    """
    from siftom.bench.results_io import load_results

    rows = [r for res in results for r in load_results(res)]
    table = reliability_table(rows)
    for t in table:
        snr = "clean" if not np.isfinite(t["snr_db"]) else f"{t['snr_db']:g} dB"
        click.echo(f"  {snr:>6}: {t['n']:4d} answers, heard as the cell they name {100 * t['heard']:.1f} %")
    inf = 'float("inf")'
    pts = [f"({t['snr_db'] if np.isfinite(t['snr_db']) else inf}, {t['heard']:.2f})" for t in table]
    click.echo("ANSWER_RELIABILITY = (" + ", ".join(pts) + ")")
