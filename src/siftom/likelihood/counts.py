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


def count_heard(transcripts: Iterable[Sequence[str] | str]) -> bool:
    """Whether any transcript (a string or a word list) holds a count word ("two", "4", ...)."""
    for t in transcripts:
        words = t.lower().split() if isinstance(t, str) else [w.lower() for w in t]
        if any(w.strip(".,!?") in COUNT_WORDS for w in words):
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
