"""What asking is worth: the expected value of information of the candidate questions, and their time."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np

from siftom.assist.askcost import QuestionCost
from siftom.assist.decision import Situation
from siftom.assist.questions import KINDS, Question, candidate_questions, evi_weighted
from siftom.assist.teamvalue import TeamValues
from siftom.inference.model import Posterior
from siftom.world.model import World

# pair questions are drawn from the most probable commands
QUESTION_POOL = 4


def question_values(tv: TeamValues, post: Posterior, pool: int = QUESTION_POOL, loss_aversion: float = 0.0,
                    reliability: float = 1.0, ask_cost: float = 0.0) -> list[tuple[float, tuple[str, str]]]:
    """EVI (steps) of "Did you mean A or B?" for every pair among the ``pool`` most probable commands.

    The truthful answer names a cell of {A}, {B}, {anything else}; it is heard as its own cell
    with probability ``reliability`` and as each of the two others with ``(1 - reliability) / 2``
    (a symmetric channel: 1 = heard perfectly, 1/3 = the answer says nothing). The robot then
    acts by expected utility given what it heard, the question's time ``ask_cost`` counted in
    the outcome (so a question followed by doing nothing is a loss, weighed as losses are):

        EVI = sum_heard max_a sum_cells P(heard | cell) E[u(b(a) - ask_cost) ; cell]
              - max_a E[u(b(a))] + ask_cost.

    Risk-neutral (``loss_aversion = 0``) this is the classic EVI, whatever ``ask_cost``; a
    question pays when ``EVI > ask_cost`` (plus any interruption penalty).
    """
    cands = [c for c, _p in post.commands[:pool] if c in tv.actions]
    v0 = float((tv.prob @ tv.utility(loss_aversion)).max())
    w = tv.prob[:, None] * tv.utility(loss_aversion, ask_cost)  # (rows, actions), after the question
    r = float(np.clip(reliability, 1.0 / 3.0, 1.0))
    conf = np.full((3, 3), (1.0 - r) / 2.0)
    np.fill_diagonal(conf, r)
    row_cmd = np.array([tv.actions[i] for i in tv.row_cmd]) if len(tv.row_cmd) else np.array([], dtype=str)
    out: list[tuple[float, tuple[str, str]]] = []
    for a, b in combinations(cands, 2):
        in_a, in_b = row_cmd == a, row_cmd == b
        cells = np.stack([w[m].sum(axis=0) for m in (in_a, in_b, ~(in_a | in_b))])  # (3, actions)
        v = float((conf @ cells).max(axis=1).sum())
        out.append((v - v0 + ask_cost, (a, b)))
    out.sort(key=lambda t: -t[0])
    return out


def question_cost(q: Question, ask_cost: float | None = None, cost_model: QuestionCost | None = None) -> float:
    """Steps a question costs the team: ``ask_cost`` when given, else its spoken length (askcost)."""
    if ask_cost is not None:
        return float(ask_cost)
    return (cost_model or QuestionCost()).expected_steps(q.text, q.answers)


def best_questions(tv: TeamValues, post: Posterior, where: Situation, loss_aversion: float = 0.0,
                   ask_cost: float | None = 0.0, kinds: Sequence[str] = KINDS,
                   pool: int = QUESTION_POOL, unit: str = "steps",
                   cost_model: QuestionCost | None = None,
                   time_as_loss: bool = True, spent: float = 0.0) -> list[tuple[float, Question]]:
    """EVI (steps) of every candidate question (assist/questions.py), best net value first.

    Each question's answer is heard with its kind's reliability here
    (``where.reliability(kind)``); see :func:`siftom.assist.questions.evi`. Its time is
    ``ask_cost`` steps, or (``ask_cost=None``) its spoken length under ``cost_model``; the
    list is ordered by EVI minus that time. ``time_as_loss``: the time is inside the
    loss-averse utility of every outcome after the question (a question followed by doing
    nothing is a loss, weighed ``1 + loss_aversion``); otherwise it is a sure price paid at
    face value, the outcomes after the answer valued from there (the classic EVI). ``spent``:
    steps already spent on earlier questions about this request (in every outcome).
    """
    qs = [q for q in candidate_questions([c for c, _p in post.commands], tv.actions, pool, kinds,
                                         lexicon_of(where.world)) if not where.settled(q)]
    if not qs:
        return []
    v0 = float((tv.prob @ tv.utility(loss_aversion, spent, unit)).max())
    out = []
    weighted: dict[float, np.ndarray] = {}  # prob * utility after a question, by the time inside it
    for q in qs:
        c = question_cost(q, ask_cost, cost_model)
        t = spent + (c if time_as_loss else 0.0)
        if t not in weighted:
            weighted[t] = tv.prob[:, None] * tv.utility(loss_aversion, t, unit)
        # the gain of asking over acting now, in the utility's unit (the time inside it, or paid after)
        net = evi_weighted(q, tv.actions, weighted[t], tv.row_cmd, v0, where.reliability(q.kind), 0.0)
        if not time_as_loss:
            net -= c if unit == "steps" else float(tv.prob @ (tv.speedup() - tv.speedup(c)).max(axis=1))
        out.append((net, c, q))
    out.sort(key=lambda t: -t[0])
    # reported as EVI in steps beside the question's time: the question pays when EVI > time
    return [(net + c, q) for net, c, q in out]


def lexicon_of(world: World) -> Any:
    """How ``world`` names its classes (its own names, else the built-in lexicon)."""
    from siftom.likelihood.lexicon import lexicon_for

    return lexicon_for(world)

