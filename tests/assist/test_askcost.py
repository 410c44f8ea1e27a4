"""The stated time model of a clarifying question (siftom.assist.askcost) and its use by ask-or-act."""

from __future__ import annotations

import pytest

from helpers import phonetic_model
from siftom.assist.askcost import QuestionCost, n_words
from siftom.assist.decide import AskOrActRule, Situation, best_questions, question_cost
from siftom.assist.questions import count_question
from siftom.assist.teamvalue import team_values
from siftom.errors import ObservationError
from siftom.inference.model import Observation
from siftom.likelihood.base import Instruction
from siftom.scenarios.base import get_scenario


def test_exchange_time_is_the_words_at_the_speaking_rate_plus_gaps_and_recognition() -> None:
    assert n_words("Which one: two plates or three plates?") == 7
    m = QuestionCost(speaking_rate_wpm=150, step_seconds=1.0, turn_gap_s=0.2, robot_latency_s=0.5)
    # 3 + 2 words at 150 words a minute = 2 s, two turn gaps, the robot's recognition
    assert m.seconds("How many plates?", "two please") == pytest.approx(2.0 + 0.4 + 0.5)
    slow = QuestionCost(speaking_rate_wpm=75, step_seconds=2.0, turn_gap_s=0.2, robot_latency_s=0.5)
    assert slow.steps("How many plates?", "two please") == pytest.approx((4.0 + 0.9) / 2.0)
    q = count_question("plate", ["deliver(plate,1)", "deliver(plate,2)", "deliver(plate,3)"])
    # before the answer: the mean answer length over the grammar's phrases
    words = [n_words(p) for cell in q.answers for p in cell]
    assert m.expected_steps(q.text, q.answers) == pytest.approx((3 + sum(words) / len(words)) * 0.4 + 0.9)
    with pytest.raises(ObservationError, match="speaking_rate_wpm"):
        QuestionCost(speaking_rate_wpm=0)


def test_ask_or_act_prices_each_question_by_its_spoken_length() -> None:
    sc = get_scenario("household-table-v0/3")
    post = phonetic_model().infer(Observation.from_scenario(sc, Instruction.from_text("get the spoons")))
    where = Situation.from_scenario(sc)
    tv = team_values(post.joint, sc.world, sc.target)
    rule = AskOrActRule()
    d = rule(post, where)
    qs = best_questions(tv, post, where, rule.loss_aversion, None, cost_model=rule.cost_model)
    # ordered by value net of each question's own time
    nets = [v - question_cost(q, None, rule.cost_model) for v, q in qs]
    assert nets == sorted(nets, reverse=True)
    assert d.ask == (nets[0] > 0)
    if d.ask:
        assert d.ask_cost == pytest.approx(question_cost(qs[0][1], None, rule.cost_model))
    # a person who speaks ten times slower makes every question dearer: the robot stops asking
    slow = AskOrActRule(cost_model=QuestionCost(speaking_rate_wpm=5.0))(post, where)
    assert not slow.ask
