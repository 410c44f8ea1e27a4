"""What the robot says is grammatical English, generated in one place (siftom.assist.phrasing_en):
number agreement, counts only where they matter, the world's own names."""

from __future__ import annotations

import pytest

from siftom.assist import phrasing_en as en
from siftom.assist.decide import Decision
from siftom.assist.questions import choose_question, confirm_question, count_question, describe
from siftom.assist.requested import absent
from siftom.language.record import Mention


@pytest.mark.parametrize(("name", "verb"), [("scissors", "are"), ("water glasses", "are"), ("forks", "are"),
                                            ("honey", "is"), ("glass", "is"), ("hummus", "is"), ("wine glass", "is"),
                                            ("jeans", "are"), ("cereal", "is"), ("bus", "is")])
def test_the_verb_agrees_with_the_name(name: str, verb: str) -> None:
    assert en.be(name) == verb
    assert en.already_with_you(name) == f"the {name} {verb} already with you"
    assert en.none_here(name) == f"there {verb} no {name} here"


@pytest.mark.parametrize(("singular", "plural"), [("plate", "plates"), ("knife", "knives"), ("glass", "glasses"),
                                                  ("water glass", "water glasses"), ("cherry", "cherries"),
                                                  ("tomato", "tomatoes"), ("scissors", "scissors"), ("box", "boxes")])
def test_plurals(singular: str, plural: str) -> None:
    assert en.plural(singular) == plural


def test_sentences() -> None:
    assert en.sorry("the scissors are already with you") == "Sorry, the scissors are already with you."
    assert en.sorry("there is no banana here.") == "Sorry, there is no banana here."
    assert en.which_one(["the glue", "the tape"]) == "Which one: the glue or the tape?"
    assert en.which_one(["the cereal", "the honey", "the sugar"]) == "Which one: the cereal, the honey or the sugar?"
    assert en.object_phrase("plate", "plates", 3, counted=True) == "three plates"
    assert en.object_phrase("plate", "plates", 1, counted=True) == "one plate"
    assert en.object_phrase("plate", "plates", 1, counted=False) == "the plate"
    assert en.object_phrase("milk", "milk", 1, counted=True, mass=True) == "the milk"
    assert en.object_phrase("scissors", "scissorses", 1, counted=True) == "the scissors"
    assert en.object_phrase("scissors", "scissorses", 2, counted=True) == "two scissors"


def test_a_choice_says_a_count_only_where_it_tells_the_two_apart() -> None:
    assert choose_question("deliver(glue,1)", "deliver(tape,1)").text == "Which one: the glue or the tape?"
    assert choose_question("deliver(plate,2)", "deliver(plate,3)").text == "Which one: two plates or three plates?"
    assert choose_question("fetch(cereal)", "fetch(honey)").text == "Which one: the cereal or the honey?"
    assert choose_question("deliver(fork,2)", "deliver(spoon,3)").text == "Which one: two forks or three spoons?"


def test_confirm_and_count_questions_agree_in_number() -> None:
    assert confirm_question("fetch(cereal)").text == "Shall I get the cereal?"
    assert confirm_question("deliver(plate,2)").text == "Shall I bring two plates?"
    assert confirm_question("deliver(scissors,1)").text == "Shall I bring the scissors?"
    assert confirm_question("deliver(scissors,2)").text == "Shall I bring two scissors?"
    assert count_question("scissors", ["deliver(scissors,1)", "deliver(scissors,2)"]).text == "How many scissors?"
    assert count_question("plate", ["deliver(plate,1)", "deliver(plate,2)"]).text == "How many plates?"
    assert describe("deliver(waterglass,3)") == "three water glasses"


def test_a_decline_for_an_object_not_here_agrees_in_number() -> None:
    base = Decision("teammate", "none", "none", 0.0, 0.0)
    for named, said in (("banana", "Sorry, there is no banana here."), ("scissors", "Sorry, there are no scissors here.")):
        d = absent(base, Mention(role="target", words=named, obj_class=None, named=named))
        assert d is not None and d.declined == said and d.reason.startswith(said[7:-1])
