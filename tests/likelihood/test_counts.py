"""Counts: heard wherever they stand, and no count favoured when none was heard."""

from __future__ import annotations

import numpy as np

from siftom.likelihood.counts import count_heard, tie_unheard_counts
from siftom.likelihood.whisper_factor import candidate_texts, count_last
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand.parse(c) for c in ("deliver(spoon,1)", "deliver(spoon,2)", "deliver(spoon,4)",
                                         "deliver(fork,2)", "deliver(fork,3)")]


def heard(text: str) -> Instruction:
    return Instruction(nbest=(Hypothesis(text, 0.0),))


def test_a_count_is_heard_as_a_word_a_digit_or_a_homophone_before_an_object():
    assert count_heard(["bring me four spoons"]) and count_heard([["get", "3", "forks"]])
    assert count_heard(["let's get to plates out"])  # Whisper's spelling of "two plates"
    assert not count_heard(["could i have the spoons", "bring them to the table for me"])


def test_unheard_counts_tie_the_plural_counts_of_each_class_only():
    scores = np.array([-1.0, -2.0, -5.0, -3.0, -4.0])
    tied = tie_unheard_counts(scores, CMDS)
    assert tied.tolist() == [-1.0, -2.0, -2.0, -3.0, -3.0]  # singular kept apart; 2 and 4 equal; forks equal


def test_a_count_after_the_object_is_scored_after_it():
    assert count_last("four spoons") == "spoons four" and count_last("spoons") == "spoons"
    texts, mode = candidate_texts(heard("hey could you pick up spoons four me"), CMDS)
    assert mode == "key"
    by_cmd = {str(c): [t for t, _ in items] for c, items in zip(CMDS, texts, strict=True)}
    assert "hey could you pick up spoons four me" in by_cmd["deliver(spoon,4)"]
    assert "hey could you pick up spoons two me" in by_cmd["deliver(spoon,2)"]
    texts, _ = candidate_texts(heard("could i have four spoons"), CMDS)  # the usual order stays
    assert "could i have four spoons" in [t for t, _ in texts[2]]
