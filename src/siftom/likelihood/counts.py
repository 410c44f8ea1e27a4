"""Counts nobody heard: the instruction likelihood then says nothing about how many.

"could i have the spoons" names the class and, by the plural, that more than one is meant, but
not how many. The phrasing model still gives the counts different scores when no count word was
heard: "the" sounds like "two" (DH AH / T UW), so "two spoons" explains "the spoons" better than
"four spoons" does, and Whisper's own language model prefers some counts to others. Those small
differences, times a confident action term, made confident wrong counts. When no transcript holds
a count word, :func:`tie_unheard_counts` gives every plural count (n >= 2) of a class the same
score (the best of them), so the count comes from the goals the actions imply (the remaining
count) and the singular / plural evidence stays.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from siftom.world.commands import RobotCommand

COUNT_WORDS = frozenset({"one", "two", "three", "four", "five", "six", "1", "2", "3", "4", "5", "6"})


# Whisper writes a spoken count as its homophone ("let's get to plates out", "for bowls"): such a word
# counts as a heard count unless a word that cannot follow a count comes next ("to the table", "for me")
HOMOPHONES = frozenset({"to", "too", "for", "fore", "won", "tree"})
NOT_AFTER_COUNT = frozenset({"the", "a", "an", "me", "you", "us", "it", "them", "him", "her", "my", "our", "your",
                             "this", "that", "some", "be", "get", "go", "have", "do", "see", "help", "dinner",
                             "lunch", "breakfast", "now", "later", "here", "there", "please", "when", "if"})


def count_heard(transcripts: Iterable[Sequence[str] | str]) -> bool:
    """Whether any transcript (a string or a word list) holds a count word ("two", "4", or a
    homophone such as "to" followed by a word a count can precede)."""
    for t in transcripts:
        words = [w.strip(".,!?") for w in (t.lower().split() if isinstance(t, str) else [w.lower() for w in t])]
        for i, w in enumerate(words):
            if w in COUNT_WORDS:
                return True
            if w in HOMOPHONES and i + 1 < len(words) and words[i + 1] not in NOT_AFTER_COUNT:
                return True
    return False


def tie_unheard_counts(scores: np.ndarray, commands: Sequence[RobotCommand]) -> np.ndarray:
    """``scores`` with every count >= 2 of a class set to the best score among them."""
    out = np.asarray(scores, dtype=float).copy()
    groups: dict[tuple[str, str], list[int]] = {}
    for i, c in enumerate(commands):
        if getattr(c, "count", 1) >= 2:
            groups.setdefault((getattr(c, "verb", ""), c.obj_class), []).append(i)
    for idx in groups.values():
        if len(idx) > 1:
            out[idx] = float(np.max(out[idx]))
    return out
