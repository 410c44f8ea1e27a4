"""Word error rate by word-level Levenshtein distance (no external dependency)."""

from __future__ import annotations

from collections.abc import Sequence

from siftom.speech.asr.base import normalise_text


def edit_distance(ref: Sequence[str], hyp: Sequence[str]) -> int:
    """Minimum substitutions + deletions + insertions turning ``ref`` into ``hyp`` (words or phonemes)."""
    prev = list(range(len(hyp) + 1))
    for i, r in enumerate(ref, 1):
        cur = [i] + [0] * len(hyp)
        for j, h in enumerate(hyp, 1):
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (r != h))
        prev = cur
    return prev[-1]


def word_errors(reference: str, hypothesis: str) -> tuple[int, int]:
    """(word edits, reference words) after normalising case and punctuation."""
    ref = normalise_text(reference).split()
    return edit_distance(ref, normalise_text(hypothesis).split()), len(ref)


def wer(reference: str, hypothesis: str) -> float:
    """Word error rate of one hypothesis (edits / reference words; may exceed 1)."""
    errors, n = word_errors(reference, hypothesis)
    return errors / n if n else float(errors > 0)


def object_word_errors(reference: str, hypothesis: str, object_words: set[str] | frozenset[str]) -> tuple[int, int]:
    """(object words of ``reference`` missing from ``hypothesis``, object words in ``reference``).

    Object words are the words that carry the command: object names, synonyms, category
    words and counts (``siftom.likelihood.background.lexicon_words``). Each reference object
    word must appear in the hypothesis (as a multiset; order is not checked), so "could you
    get the milk for me" heard as "could you get the milk some me" has no object-word error,
    and heard as "could you get the mail" has one.
    """
    hyp = normalise_text(hypothesis).split()
    missed = total = 0
    for w in normalise_text(reference).split():
        if w in object_words:
            total += 1
            if w in hyp:
                hyp.remove(w)
            else:
                missed += 1
    return missed, total
