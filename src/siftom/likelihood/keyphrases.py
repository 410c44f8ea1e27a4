"""The words of a command that the audio must hold: key phrases, their heard forms, phrasings.

Shared by the acoustic likelihood (alignment) and its Whisper factor (teacher forcing); it
imports neither, so both can use it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from siftom.logspace import logsumexp
from siftom.world.commands import RobotCommand

if TYPE_CHECKING:
    from siftom.likelihood.lexicon import Lexicon


def top_phrasings(command: RobotCommand, k: int = 1, lexicon: Lexicon | None = None) -> list[tuple[str, float]]:
    """The ``k`` most likely phrasings of a command (default phrasing model; ``lexicon``: the
    built-in one when None)."""
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import phrasings

    items = sorted(phrasings(command, lexicon or default_lexicon()), key=lambda t: -t[1])[:k]
    top = float(logsumexp([lp for _, lp in items]))
    return [(t, lp - top) for t, lp in items]


def closest_phrasing(command: RobotCommand, heard: str, lexicon: Lexicon | None = None) -> tuple[str, float]:
    """The phrasing of ``command`` with the smallest word edit distance to ``heard``."""
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import phrasings
    from siftom.speech.metrics import edit_distance

    words = heard.lower().split()
    best = min(phrasings(command, lexicon or default_lexicon()),
               key=lambda t: (edit_distance(t[0].lower().split(), words), -t[1]))
    return best[0], 0.0


def key_phrases(command: RobotCommand, mass: float = 0.8, most: int = 2,
                lexicon: Lexicon | None = None) -> list[tuple[str, float]]:
    """(content words, log prior) of a command: what distinguishes it from the others.

    Only the likeliest key phrases are kept (until ``mass`` of the prior, at most ``most``;
    each costs one alignment), renormalised so that a class with many synonyms is not
    penalised for the ones left out.
    """
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import content_prior

    items = sorted(((c, lp) for c, lp in content_prior(command, lexicon or default_lexicon()) if c.strip()),
                   key=lambda t: -t[1])
    kept: list[tuple[str, float]] = []
    total = 0.0
    for c, lp in items:
        kept.append((c, lp))
        total += float(np.exp(lp))
        if total >= mass or len(kept) >= most:
            break
    z = float(logsumexp([lp for _, lp in kept])) if kept else 0.0
    return [(c, lp - z) for c, lp in kept]


def key_word_forms(phrases: Iterable[str]) -> set[str]:
    """The words of the key phrases, each also in its plural ("oranges" names orange juice's "orange")."""
    from siftom.likelihood.lexicon import pluralize

    words = {w for k in phrases for w in k.split()}
    return words | {pluralize(w) for w in words}


def names(said: Sequence[str], phrases: Iterable[str]) -> bool:
    """Whether the words ``said`` hold one of the key phrases, its last word singular or plural."""
    from siftom.likelihood.lexicon import pluralize

    text = f" {' '.join(said)} "
    return any(f" {f} " in text for k in phrases for f in (k, pluralize(k)))


def heard_frame(words: Sequence[tuple[str, float, float]], key_words: set[str]
                ) -> tuple[float, float | None, tuple[str, ...], tuple[str, ...]] | None:
    """Where to put each command's key phrase in what was heard, or None when no key word was heard.

    Returns (start, end or None for the end of the audio, words before, words after): the key
    phrase replaces the heard key words (the first to the last 1-best word that belongs to any
    command's key phrase); the word just before and the word just after them are kept as
    heard, and the audio outside those words is dropped. Free speech around the object costs
    every command the same, and is mostly not aligned at all.
    """
    idx = [i for i, (w, _, _) in enumerate(words) if w in key_words]
    if not idx:
        return None
    i0, i1 = idx[0], idx[-1]
    j = max(0, i0 - 1)
    start = max(0.0, words[j][1] - 0.05) if i0 > 0 else 0.0
    before = tuple(w for w, _, _ in words[j:i0])
    after = tuple(w for w, _, _ in words[i1 + 1:i1 + 2])
    # the audio after the next word holds other free words: stop at the one after that
    end = words[i1 + 2][1] + 0.05 if i1 + 2 < len(words) else None
    return start, end, before, after
