"""The open-vocabulary scene recogniser, shaped by the phonetic channel's meaning vocabulary.

It lives in the likelihood layer because it asks :mod:`siftom.likelihood.background` which
common English words sound like an object name, synonym, category word or count; the decoder
itself is :class:`siftom.speech.asr.pocketsphinx.PocketsphinxEngine` (docs/speech.md, "Open
vocabulary"). Registered as the ASR engine ``pocketsphinx-open``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from siftom.speech.asr.pocketsphinx import PocketsphinxEngine, open_vocabulary_engine


def distinct_words(candidates: Sequence[tuple[str, float]], phrase_words: Iterable[str]) -> tuple[tuple[str, float], ...]:
    """The candidates that sound like no meaning word of the phrasings (relevance 0 under the
    phonetic channel's background model): an open LM that can say them cannot turn an object
    name into a common word that sounds like it ("mill" for milk, "two" for a count)."""
    from siftom.likelihood.background import MeaningVocabulary

    meaning = MeaningVocabulary(phrase_words)
    return tuple((w, lp) for w, lp in candidates if w in meaning.words or meaning.relevance(w) == 0.0)


def meaning_words(vocabulary: Sequence[str]) -> set[str]:
    """The phrasings' words that can carry meaning (object names, synonyms, category words,
    counts): every word but the phrasing grammar's filler words."""
    from siftom.likelihood.phrasing import FILLER_WORDS
    from siftom.speech.asr.base import normalise_text

    return {w for p in vocabulary for w in normalise_text(p).split()} - FILLER_WORDS


def open_engine(vocabulary: Sequence[str], boost: float = 1.0, **options: Any) -> PocketsphinxEngine:
    """``pocketsphinx-open``: the scene's phrasings plus the generic LM's 2000 most frequent
    words that sound like no meaning word, decoded without the flat-lexicon pass; ``boost``
    multiplies the unigram probability of the meaning words (:func:`meaning_words`)."""
    options.setdefault("background_filter", distinct_words)
    if boost != 1.0:
        options.setdefault("boost_words", sorted(meaning_words(vocabulary)))
    return open_vocabulary_engine(vocabulary, boost=boost, **options)
