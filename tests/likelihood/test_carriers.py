"""Carrier files (siftom dataset build --phrasings) and the shipped free-phrasing sets."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import DatasetError
from siftom.likelihood.carriers import (
    load_carriers,
    noun_phrase_of,
    parse_carriers,
    sample_with_carriers,
    shipped_carrier_sets,
)
from siftom.likelihood.phrasing import CARRIERS, phrasings, sample_phrasing
from siftom.world.commands import RobotCommand


def test_comments_blank_lines_and_case_are_handled():
    text = "# my carriers\n\n  Um could you get {np}  for me\n# another comment\n{np} please\n{np} please\n"
    assert parse_carriers(text) == ("um could you get {np} for me", "{np} please")


@pytest.mark.parametrize("text", ["", "# only a comment\n", "bring me the milk\n"])
def test_a_file_without_np_is_a_clear_error(text):
    with pytest.raises(DatasetError, match=r"\{np\}"):
        parse_carriers(text)


def test_other_braces_are_refused():
    with pytest.raises(DatasetError, match="braces"):
        parse_carriers("bring me {np} and {x}\n")


def test_missing_file_names_the_shipped_sets(tmp_path):
    with pytest.raises(DatasetError, match="free-v0"):
        load_carriers(tmp_path / "nope.txt")


def test_shipped_sets_are_large_and_not_the_grammar():
    assert {"free-v0", "free-heldout-v0"} <= set(shipped_carrier_sets())
    dev, held = load_carriers("free-v0"), load_carriers("free-heldout-v0")
    assert len(dev) >= 60 and len(held) >= 30
    grammar = {t for cs in CARRIERS.values() for t, _ in cs}
    assert not (set(dev) | set(held)) & grammar
    assert not set(dev) & set(held)


def test_samples_keep_the_grammar_noun_phrase_and_vary_the_carrier():
    carriers = load_carriers("free-v0")
    cmd = RobotCommand("deliver", "fork", 3)
    seen = set()
    for seed in range(40):
        text = sample_with_carriers(cmd, None, np.random.default_rng(seed), carriers,
                                    carrier_rng=np.random.default_rng([seed, 1]))
        grammar = sample_phrasing(cmd, None, np.random.default_rng(seed))
        assert noun_phrase_of(grammar, cmd) in text
        seen.add(text)
    assert len(seen) > 20
    # same seeds, same sentences
    again = sample_with_carriers(cmd, None, np.random.default_rng(0), carriers,
                                 carrier_rng=np.random.default_rng([0, 1]))
    assert again == sample_with_carriers(cmd, None, np.random.default_rng(0), carriers,
                                         carrier_rng=np.random.default_rng([0, 1]))


def test_every_grammar_phrasing_has_its_noun_phrase():
    for cmd in (RobotCommand("deliver", "fork", 3), RobotCommand("fetch", "onion", 1),
                RobotCommand("deliver", "spoon", 1), RobotCommand("fetch", "milk", 1)):
        for text, _ in phrasings(cmd):
            assert noun_phrase_of(text, cmd) in text.replace("rest of the", "the")


def test_dataset_options_check_the_file(tmp_path):
    from siftom.people.stimuli import BuildOptions

    bad = tmp_path / "bad.txt"
    bad.write_text("bring me the milk\n", encoding="utf-8")
    with pytest.raises(DatasetError, match=r"\{np\}"):
        BuildOptions(phrasings=str(bad))
    opts = BuildOptions(phrasings="free-v0")
    assert opts.to_json()["phrasings"] == "free-v0"
    assert "phrasings" not in BuildOptions().to_json()  # old datasets keep their options
