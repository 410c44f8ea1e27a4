"""The phonetic channel's background model: words that sound like no object name, synonym,
category word or count cost the same under every command (issue 9, docs/likelihoods.md)."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.likelihood.background import MeaningVocabulary, lexicon_words
from siftom.likelihood.base import Instruction
from siftom.likelihood.lexicon import HOUSEHOLD_CLASSES, KITCHEN_ITEMS, default_lexicon
from siftom.likelihood.phonetic import PhoneticLikelihood
from siftom.world.commands import RobotCommand

KITCHEN = [RobotCommand("fetch", c) for c in KITCHEN_ITEMS]
HOUSEHOLD = [RobotCommand("deliver", c, n) for c in HOUSEHOLD_CLASSES for n in range(1, 5)]


@pytest.fixture(scope="module")
def vocab():
    return MeaningVocabulary(lexicon_words(default_lexicon()))


def test_meaning_words_are_names_synonyms_categories_and_counts():
    words = lexicon_words(default_lexicon())
    assert {"cereal", "forks", "cutlery", "glass", "three", "juice"} <= words
    assert not {"the", "me", "please"} & words


@pytest.mark.parametrize("word", ["cereal", "serial", "silver", "flower", "tree", "forks", "too"])
def test_mishearings_of_object_words_stay_relevant(vocab, word):
    assert vocab.relevance(word) > 0.5


@pytest.mark.parametrize("word", ["breakfast", "somebody", "recipe", "forgot", "anywhere", "favor"])
def test_ordinary_words_are_background(vocab, word):
    assert vocab.relevance(word) < 0.5


def test_a_background_word_costs_the_same_under_every_command():
    lik = PhoneticLikelihood()
    base = lik.log_prob(Instruction.from_text("pass me the cereal"), KITCHEN).log_probs
    more = lik.log_prob(Instruction.from_text("pass me the cereal somebody forgot breakfast"), KITCHEN).log_probs
    shift = more - base
    assert np.ptp(shift) < 0.25 * np.ptp(base)
    # without the background model the same words re-rank the commands
    old = PhoneticLikelihood(background=False)
    old_shift = (old.log_prob(Instruction.from_text("pass me the cereal somebody forgot breakfast"), KITCHEN).log_probs
                 - old.log_prob(Instruction.from_text("pass me the cereal"), KITCHEN).log_probs)
    assert np.ptp(old_shift) > 2 * np.ptp(shift)


@pytest.mark.parametrize(("text", "target"), [
    ("i think we're out of milk on the table could you bring some", RobotCommand("fetch", "milk")),
    ("do me a favor and get the bread", RobotCommand("fetch", "bread")),
    ("could you check if there's the salt and bring it", RobotCommand("fetch", "salt")),
    ("um could you get the honey for me", RobotCommand("fetch", "honey")),
])
def test_free_carriers_keep_the_object_on_top(text, target):
    lp = PhoneticLikelihood().log_prob(Instruction.from_text(text), KITCHEN).log_probs
    assert KITCHEN[int(np.argmax(lp))] == target


def test_counts_still_count_inside_free_speech():
    lik = PhoneticLikelihood()
    lp = lik.log_prob(Instruction.from_text("before we start i need three forks if you don't mind"), HOUSEHOLD).log_probs
    assert HOUSEHOLD[int(np.argmax(lp))] == RobotCommand("deliver", "fork", 3)


def test_new_class_names_become_meaning_words():
    lik = PhoneticLikelihood()
    cmds = [RobotCommand("fetch", "ketchup"), RobotCommand("fetch", "milk")]
    lp = lik.log_prob(Instruction.from_text("um could you get the ketchup for me"), cmds).log_probs
    assert int(np.argmax(lp)) == 0
    assert lik.vocabulary(cmds).relevance("ketchup") == 1.0


def test_relevance_range_is_checked():
    from siftom.errors import ObservationError

    with pytest.raises(ObservationError, match="relevance_range"):
        PhoneticLikelihood(relevance_range=(0.5, 0.2))
