"""Readings are hypotheses: whether anybody asked is weighed from every recogniser, and the
utterance model reads repairs, negations and statements the way people say them."""

from __future__ import annotations

import pytest

from siftom.inference.understood import hearings_of, transcript_reliability, understanding_of
from siftom.language.parse import read
from siftom.language.understand import CELLS, OPEN, SCENE, Hearing, _channel, understand_heard
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

KITCHEN = ("beans", "bread", "cereal", "flour", "milk", "onion", "sugar", "yogurt")


def _cmds(classes: tuple[str, ...] = KITCHEN) -> list[RobotCommand]:
    return [RobotCommand("fetch", c, 1) for c in classes]


def test_a_garbled_transcript_of_low_confidence_does_not_outweigh_a_request_heard_word_for_word() -> None:
    # the scene recogniser heard the request; Whisper wrote made-up words at low confidence
    nbest = Instruction(nbest=(Hypothesis("fetch me the yogurt please", 0.0),), scene_words=True)
    u, ev = understanding_of(nbest, _cmds(), ("achime my older clean",), None, -1.2)
    assert u.request and u.p_request > 0.5 and "no_instruction" not in ev
    # the same words, but Whisper sure of them: its reading speaks with its confidence
    sure, _ = understanding_of(nbest, _cmds(), ("achime my older clean",), None, -0.1)
    assert sure.p_request < u.p_request


def test_room_talk_heard_clearly_outweighs_command_words_a_scene_recogniser_writes_into_it() -> None:
    nbest = Instruction(nbest=(Hypothesis("the one carrot still you i still j", 0.0),), scene_words=True)
    u, ev = understanding_of(nbest, _cmds(), ("the weather is really nice today",), None, -0.2)
    assert not u.request and ev.get("no_instruction")
    # the scene recogniser's words alone say little either way
    alone = understand_heard(hearings_of(nbest), KITCHEN)
    assert 0.2 < alone.p_request < 0.95


def test_a_recogniser_of_no_reliability_says_nothing_and_the_prior_stays() -> None:
    h = Hearing(("thanks",), (1.0,), OPEN, 0.0, "Whisper")
    assert understand_heard([h], KITCHEN).p_request == pytest.approx(0.5)


def test_transcript_reliability_grows_with_whisper_s_confidence() -> None:
    lps = [-2.0, -1.0, -0.8, -0.5, -0.2]
    rel = [transcript_reliability(lp) for lp in lps]
    assert rel == sorted(rel) and rel[2] == pytest.approx(0.5) and transcript_reliability(None) == 1.0
    assert transcript_reliability(float("-inf")) == 0.0


@pytest.mark.parametrize("channel", [OPEN, SCENE])
def test_every_channel_is_two_distributions_over_the_cells(channel: object) -> None:
    cells = channel.cells  # type: ignore[attr-defined]
    assert {c for c, _, _ in cells} == set(CELLS)
    assert sum(p for _, p, _ in cells) == pytest.approx(1.0) and sum(q for _, _, q in cells) == pytest.approx(1.0)


def test_a_channel_missing_a_cell_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match="frame-empty"):
        _channel("broken", {c: 1.0 for c in CELLS if c != "frame-empty"}, {c: 1.0 for c in CELLS})


@pytest.mark.parametrize("text, roles", [
    ("the jam the honey", [("retracted", "jam"), ("target", "honey")]),
    ("get me the lettuce the chicken", [("retracted", "lettuce"), ("target", "chicken")]),
    ("can you get the carrot, uh, the onion", [("retracted", "carrot"), ("target", "onion")]),
    ("get me the jam, scratch that, the honey", [("retracted", "jam"), ("target", "honey")]),
    ("the flour, or rather the sugar", [("retracted", "flour"), ("target", "sugar")]),
    ("the jam. never mind, the honey", [("retracted", "jam"), ("target", "honey")]),
    ("get me the bowls, make it the plates instead", [("retracted", "bowls"), ("target", "plates")]),
    ("bring me three mugs, no, three water glasses", [("retracted", "mugs"), ("target", "water glasses")]),
    # a list says "and"; a phrase that says whose or where is no repair
    ("the olive oil, the coffee and the milk", [("target", "olive oil"), ("target", "coffee"), ("target", "milk")]),
    ("would you bring the plate my way", None),
    ("I won't need the knives", [("negated", "knives")]),
    ("please leave the milk where it is", [("negated", "milk")]),
    ("anything but the sugar", [("target", ""), ("negated", "sugar")]),
    ("Oh, before I forget, I'd like you to bring the cheese", [("target", "cheese")]),
    ("could you bring me the beans, the onion's already chopped", [("target", "beans"), ("context", "onion"),
                                                                   ("context", "chopped")]),
    ("the cereal with a bit of brown sugar", [("target", "cereal"), ("context", "bit"), ("context", "brown sugar")]),
    # a bare "no" between two names restates; after a relation or a list it quantifies
    ("pasta, no, olive oil", [("retracted", "pasta"), ("target", "olive oil")]),
    ("the pasta with no garlic", [("target", "pasta"), ("negated", "garlic")]),
    ("cereal and no milk", [("target", "cereal"), ("negated", "milk")]),
    # the speaker as the request verb's subject tells what they do; a modal before it still asks
    ("hmm, where did I put that", [("context", "")]),
    ("get the tortilla, I'll put the ham in it", [("target", "tortilla"), ("context", "ham")]),
    ("I will put the bowl away, bring me the milk", [("context", "bowl away"), ("target", "milk")]),
    ("can I get the milk", [("target", "milk")]),
    ("let's get the milk", [("target", "milk")]),
    ("bring bread a i'm hand tortilla", [("target", "bread"), ("target", ""), ("target", "tortilla")]),
    ("but we bring me the beans", [("target", "beans")]),
    # a bare word between a negated auxiliary and a noun phrase is the verb it negates
    ("please don't touch the bowls", [("negated", "bowls")]),
    ("do not drag the pasta", [("negated", "pasta")]),
    ("no sugar", [("negated", "sugar")]),
    # "<word> me <object>" opening a clause is a request, whatever verb was heard
    ("drink me the napkins", [("target", "napkins")]),
    ("has me the beans", [("target", "beans")]),
    ("and fix me a sandwich", [("target", "sandwich")]),
    ("I have the beans", [("context", "beans")]),
    # a slot before a negated verb with an object of its own is its subject, not the request
    ("stop, don't grab the pasta", [("context", "stop"), ("negated", "pasta")]),
    ("the kids don't want the milk", [("context", "kids"), ("negated", "milk")]),
    ("the milk, don't forget it", [("target", "milk")]),
])
def test_repairs_negations_and_statements_are_read_as_said(text: str, roles: list[tuple[str, str]] | None) -> None:
    r = read(text)
    got = [(s.role, r.slot_words(s)) for s in r.slots]
    if roles is None:  # "my way": the plate stays the target
        assert ("target", "plate") in got and ("retracted", "plate") not in got
    else:
        assert got == roles


def test_a_transcript_speaks_as_far_as_it_is_the_words_said() -> None:
    # the words as said with probability r, else misheard: at r = 1 the channel's full ratio, at
    # r = 0 nothing, and in between never more than the words as said would say
    from siftom.language.understand import OPEN, Hearing, hearing_log_odds

    classes = ["beans", "milk"]
    for text in ("i'm on the phone", "pass me the beans"):
        full = hearing_log_odds(Hearing((text,), (1.0,), OPEN, 1.0), classes)
        odds = [hearing_log_odds(Hearing((text,), (1.0,), OPEN, r), classes) for r in (0.0, 0.2, 0.5, 0.8, 1.0)]
        assert odds[0] == pytest.approx(0.0) and odds[-1] == pytest.approx(full)
        assert all(abs(a) <= abs(b) + 1e-12 for a, b in zip(odds, odds[1:], strict=False))
    # a garbled room-talk reading at low confidence no longer outweighs a request in the N-best
    low = hearing_log_odds(Hearing(("i'm on the phone",), (1.0,), OPEN, 0.3), classes)
    assert -1.5 < low < 0.0
