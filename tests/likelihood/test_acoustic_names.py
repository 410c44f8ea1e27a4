"""Which heard words name a command's key phrase (the acoustic likelihood's pruning and carriers)."""

from __future__ import annotations

from siftom.likelihood.acoustic import key_word_forms, names


def test_key_words_include_their_plurals():
    assert key_word_forms(["orange juice", "glass", "one onion"]) >= {
        "orange", "oranges", "juice", "glass", "glasses", "onion", "onions", "one"}


def test_a_phrase_is_named_only_as_whole_words():
    assert names(["could", "you", "bring", "me", "an", "onion"], ["onion"])
    assert names(["i", "still", "need", "the", "oranges", "juices"], ["orange juice"]) is False
    assert names(["two", "orange", "juices", "please"], ["orange juice"])
    assert not names(["bring", "me", "the", "bunion"], ["onion"])
    assert not names([], ["onion"])
