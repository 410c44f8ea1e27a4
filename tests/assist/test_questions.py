"""Questions with answer grammars (siftom.assist.questions): cells, EVI and the answer update."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import phonetic_model
from siftom.assist.decide import Situation, question_values, with_answer
from siftom.assist.questions import (
    answer_log_likelihood_cells,
    candidate_questions,
    channel,
    choose_question,
    confirm_question,
    count_question,
    evi,
)
from siftom.assist.teamvalue import team_values
from siftom.errors import ObservationError
from siftom.inference.model import Observation
from siftom.likelihood.base import Instruction
from siftom.scenarios.base import get_scenario
from siftom.speech.asr.pocketsphinx import expand_vocabulary

SPOONS = [f"deliver(spoon,{k})" for k in range(1, 5)]


def _posterior(sid: str, words: str):
    sc = get_scenario(sid)
    return sc, phonetic_model().infer(Observation.from_scenario(sc, Instruction.from_text(words)))


def test_cells_and_heard_answers():
    q = count_question("spoon", [*SPOONS, "deliver(fork,2)"])
    assert q.text == "How many spoons?" and q.options == tuple(SPOONS) and q.n_cells == 5
    assert q.cell("deliver(spoon,3)") == 2 and q.cell("deliver(fork,2)") == 4
    assert q.heard_cell("three please") == 2 and q.heard_cell("nothing") == 4 and q.heard_cell("i don't need any") == 4
    assert q.heard_cell("please") is None and q.heard_cell("two three") is None  # unclear: no update
    c = choose_question("fetch(cereal)", "fetch(oatmeal)")
    assert c.text == "Which one: the cereal or the oatmeal?"
    assert [c.heard_cell(t) for t in ("the oatmeal please", "the cereal", "neither of them")] == [1, 0, 2]
    assert choose_question("deliver(plate,2)", "deliver(plate,3)").answers[0][0] == "two"
    y = confirm_question("deliver(fork,3)")
    assert y.text == "Shall I bring three forks?" and [y.heard_cell(t) for t in ("yes please", "no thanks")] == [0, 1]
    with pytest.raises(ObservationError):
        choose_question("fetch(cereal)", "fetch(cereal)")


def test_answer_grammars_are_taken_as_phrases_by_the_recogniser():
    # single words would be expanded into request templates ("pass me the yes")
    for q in (confirm_question("fetch(milk)"), choose_question(*SPOONS[:2]), count_question("spoon", SPOONS)):
        assert set(expand_vocabulary(q.grammar())) == set(q.grammar())


def test_fetch_domains_get_no_count_question():
    qs = candidate_questions(["fetch(cereal)", "fetch(oatmeal)", "fetch(milk)"], ["fetch(cereal)", "fetch(oatmeal)",
                                                                                  "fetch(milk)", "none"])
    assert {q.kind for q in qs} == {"confirm", "choose"} and len(qs) == 3 + 3


def test_choice_value_matches_the_pair_questions_independent_formula():
    sc, post = _posterior("household-table-v0/3", "get the spoons")
    tv = team_values(post.joint, sc.world, sc.target)
    for r in (0.5, 0.8, 1.0):
        ref = {pair: v for v, pair in question_values(tv, post, loss_aversion=3.0, reliability=r, ask_cost=2.0)}
        v0 = float((tv.prob @ tv.utility(3.0)).max())
        for pair, v in ref.items():
            q = choose_question(*pair)
            assert evi(q, tv.actions, tv.prob, tv.row_cmd, tv.utility(3.0, 2.0), v0, r, 2.0) == pytest.approx(v)


def test_question_values_are_zero_at_chance_and_grow_with_reliability():
    sc, post = _posterior("household-table-v0/3", "get the spoons")
    tv = team_values(post.joint, sc.world, sc.target)
    v0 = float((tv.prob @ tv.utility(0.0)).max())
    for q in candidate_questions([c for c, _ in post.commands], tv.actions):
        vals = [evi(q, tv.actions, tv.prob, tv.row_cmd, tv.utility(0.0), v0, r, 0.0)
                for r in (1.0 / q.n_cells, 0.6, 0.9, 1.0)]
        assert vals[0] == pytest.approx(0.0, abs=1e-9)
        assert all(b >= a - 1e-9 for a, b in zip(vals, vals[1:], strict=False))
    # an unsaid count is worth asking about: the count question is the most valuable when heard well
    where = Situation.from_scenario(sc)
    from siftom.assist.decide import best_questions

    assert best_questions(tv, post, where, 0.0)[0][1].kind in ("count", "choose")


def test_answer_update_uses_the_kinds_channel():
    sc, post = _posterior("household-table-v0/3", "get the spoons")
    q = count_question("spoon", [str(c) for c in post.joint.commands])
    cmds = [str(c) for c in post.joint.commands]
    r = 0.8
    ll = answer_log_likelihood_cells(q, cmds, 2, r)  # heard "three"
    after = with_answer(post, ll, "three")
    # independent reference: P(c | heard) ∝ P(c) (r if c says three else (1 - r) / 4)
    ref = {c: post.prob(c) * (r if c == "deliver(spoon,3)" else (1 - r) / 4) for c in cmds}
    z = sum(ref.values())
    for c, p in after.commands[:5]:
        assert p == pytest.approx(ref[c] / z, rel=1e-6)
    assert np.all(answer_log_likelihood_cells(q, cmds, None, r) == 0.0)  # nothing made out: no update
    assert np.allclose(channel(3, 0.1).diagonal(), 1 / 3)  # below chance is chance
