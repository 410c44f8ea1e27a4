"""The answer to a question closes the loop: a reply is weighed with the request that led to it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.assist.questions import choose_question, confirm_question
from siftom.assist.reply import Pending, after_reply, cell_named
from siftom.errors import ObservationError
from siftom.inputs import resolve_scene
from siftom.observation import Instruction
from siftom.observer import Observer

SCENE = "kitchen-cereal-v0"


# what a recogniser heard in noise: the flour, the cereal (likelier by the actions), or an object lost
FLOUR_OR_CEREAL = Instruction.from_nbest([("can you get me the flour", 0.0), ("can you get me the cereal", -5.0),
                                          ("can you get me the", -20.0)])


@pytest.fixture(scope="module")
def asked():
    """A request heard as the flour or the cereal is asked about ("the cereal or the flour?")."""
    obs = Observer()
    online = obs.online(resolve_scene(SCENE, None))
    first = obs.answer(online, FLOUR_OR_CEREAL)
    assert first.action == "ask" and "fetch(cereal)" in first.decision.options, first.decision
    assert first.pending is not None and first.to_json()["awaiting_reply"] is True
    return obs, online, first


@pytest.mark.parametrize(("reply", "want"), [
    (None, "fetch(cereal)"),  # the plainest answer of the question's first cell ("yes", "the cereal")
    ("no, the flour", "fetch(flour)"),
    ("no I need the sugar", "fetch(sugar)"),
    ("the honey please", "fetch(honey)"),
])
def test_a_reply_that_answers_is_carried_out(asked, reply, want):
    obs, online, first = asked
    said = reply or first.decision.asked.answers[0][0]
    got = obs.answer(online, Instruction.from_text(said), pending=first.pending)
    assert got.action == "act" and str(got.command) == want, (said, got.decision)
    assert got.reply_to == first.decision.question and got.pending is None
    assert got.decision.reason.startswith("reply to")


def test_rejecting_the_options_moves_the_belief_away_and_does_not_ask_the_same_again(asked):
    obs, online, first = asked
    q = first.decision.asked
    got = obs.answer(online, Instruction.from_text(q.answers[-1][0]), pending=first.pending)  # "neither" / "no"
    assert got.prob("fetch(cereal)") < first.prob("fetch(cereal)") and got.reply_to == q.text
    assert got.action != "ask" or got.decision.question != q.text
    assert got.command is None or str(got.command) not in q.options


@pytest.mark.parametrize("talk", ["hmm what a day", "thanks", "the weather is nice today"])
def test_words_that_answer_nothing_do_nothing_and_the_question_waits(asked, talk):
    obs, online, first = asked
    got = obs.answer(online, Instruction.from_text(talk), pending=first.pending)
    assert got.action == "none" and got.command is None and got.reply_to is None
    assert got.pending is first.pending


def test_silence_leaves_the_question_waiting(asked):
    obs, online, first = asked
    got = obs.answer(online, None, pending=first.pending)
    assert got.action == "none" and got.pending is first.pending


def test_a_pending_question_survives_json(asked):
    _obs, _online, first = asked
    p = first.pending
    assert Pending.from_json(p.to_json()) == p
    with pytest.raises(ObservationError, match="pending question"):
        Pending.from_json({"question": p.question.to_json()})
    with pytest.raises(ObservationError, match="question record"):
        Pending.from_json({**p.to_json(), "question": {"kind": "confirm"}})


def test_the_cell_is_read_through_punctuation_and_the_nbest():
    q = confirm_question("fetch(cereal)")
    assert cell_named(q, Instruction.from_text("No, thanks.")) == 1
    assert cell_named(q, Instruction.from_text("Yes!")) == 0
    assert cell_named(q, Instruction.from_nbest([("hmm", 0.0), ("yes", -1.0)])) == 0
    assert cell_named(q, Instruction.from_text("hmm")) is None
    c = choose_question("fetch(cereal)", "fetch(sugar)")
    assert cell_named(c, Instruction.from_text("the sugar please")) == 1


@settings(max_examples=20, deadline=None)
@given(st.floats(-30, 0))
def test_a_reply_with_no_cell_and_flat_evidence_changes_nothing(ev):
    """Bayes: evidence that is the same for every command leaves the posterior as it is."""
    obs = Observer()
    online = obs.online(resolve_scene(SCENE, None))
    base = obs.answer(online, Instruction.from_text("pass me the cereal")).posterior
    q = confirm_question("fetch(cereal)")
    flat = Pending(q, tuple((str(c), ev) for c in base.joint.commands), "fetch(cereal)")
    after = after_reply(base, flat, None)
    before = dict((str(c), p) for c, p in base.commands)
    for c, p in after.commands:
        assert np.isclose(p, before[str(c)], atol=1e-9)
