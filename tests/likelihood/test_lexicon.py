import json

import pytest

from siftom.errors import ObservationError, UnknownNameError
from siftom.likelihood.lexicon import (
    HOUSEHOLD_CLASSES,
    KITCHEN_ITEMS,
    LexEntry,
    Lexicon,
    default_lexicon,
    pluralize,
)


def test_default_lexicon_covers_household_and_kitchen_classes():
    lex = default_lexicon()
    for c in (*HOUSEHOLD_CLASSES, *KITCHEN_ITEMS):
        assert c in lex
    assert lex.entry("wineglass").singular == "wine glass"
    assert lex.entry("wineglass").plural == "wine glasses"
    assert "glasses" in {n.plural for n in lex.entry("waterglass").names}
    assert "cup" in {n.singular for n in lex.entry("mug").names}
    assert lex.entry("cereal").mass and lex.entry("milk").mass and not lex.entry("fork").mass
    assert lex.entry("tomato_sauce").singular == "tomato sauce"


def test_categories_cover_several_classes():
    lex = default_lexicon()
    assert {c.word for c in lex.categories_of("fork")} >= {"cutlery", "silverware"}
    assert "dishes" in {c.word for c in lex.categories_of("bowl")}
    assert lex.categories_of("cereal") == ()


def test_round_trip_through_json():
    lex = default_lexicon()
    again = Lexicon.from_dict(json.loads(json.dumps(lex.to_dict())))
    assert again == lex
    assert again.fingerprint == lex.fingerprint
    assert hash(again) == hash(lex)


def test_unlisted_class_gets_a_spoken_default():
    e = default_lexicon().entry("maple_leaf")
    assert e.singular == "maple leaf" and e.plural == "maple leaves"


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        ({}, "classes"),
        ({"classes": {"Fork!": {}}}, "lowercase"),
        ({"classes": {"fork": {"singular": "Fork"}}}, "lowercase words"),
        ({"classes": {"fork": {"colour": "red"}}}, "unknown keys"),
        ({"classes": {"fork": {"synonyms": [3]}}}, "synonym"),
        ({"classes": {"fork": {}}, "categories": {"cutlery": {"classes": ["spork"]}}}, "spork"),
    ],
)
def test_malformed_lexicons_are_rejected_with_a_hint(bad, match):
    with pytest.raises(ObservationError, match=match):
        Lexicon.from_dict(bad)


def test_duplicate_classes_are_rejected():
    e = LexEntry.default("fork")
    with pytest.raises(ObservationError, match="twice"):
        Lexicon((e, e))


def test_require_suggests_close_names():
    with pytest.raises(UnknownNameError, match="cereal"):
        default_lexicon().require("cereall")


@pytest.mark.parametrize(
    ("sg", "pl"),
    [("fork", "forks"), ("knife", "knives"), ("dish", "dishes"), ("glass", "glasses"),
     ("cherry", "cherries"), ("wine glass", "wine glasses"), ("potato", "potatoes")],
)
def test_pluralize(sg, pl):
    assert pluralize(sg) == pl
