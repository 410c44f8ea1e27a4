"""How near heard words are to the words of a scene's commands, against chance.

The utterance model (``siftom.language.understand``) names each object slot by the class whose
words it sounds most like, and counts it as naming that object only when it does so better than
chance:

    r(w) <= t(|w|)

with r the relative phoneme cost of :class:`~siftom.likelihood.background.MeaningVocabulary`
(0 for an exact command word, ~1 for nothing alike) and t the chance level: the 1st percentile of
r that random English words reach against the commands of the built-in scenes, per word length in
phonemes (``python studies/nearness.py`` measures it; docs/speech.md). So a heard word
names an object when it matches one better than 99 % of random words would.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from siftom.likelihood.background import MeaningVocabulary
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phonemes import normalize_text, word_phonemes
from siftom.likelihood.phrasing import FILLER_WORDS, NUMBER_WORDS, content_prior

# t(length in phonemes): the 1st percentile of r for random cmudict words (seed 0, 4000 words)
# against the commands of every built-in scene; `python studies/nearness.py` (docs/speech.md)
CHANCE_R: dict[int, float] = {2: 0.076, 3: 0.181, 4: 0.147, 5: 0.21, 6: 0.256, 7: 0.35, 8: 0.406}
CHANCE_QUANTILE = 0.01
# the hypotheses that count as heard: those with at least this share of the N-best weight
# softmax(score / ASR_TEMPERATURE), the weights of the phonetic likelihood (phonetic.py)
MIN_WEIGHT = 0.05
ASR_TEMPERATURE = 10.0
PAIR_EDGE = 1.0  # a pair must sound like a whole command word (background.py)


def scene_words(commands: Sequence[Any], lexicon: Lexicon | None = None) -> frozenset[str]:
    """The content words of every phrasing of ``commands`` (no fillers, no number words)."""
    return _scene_words(tuple(commands), lexicon or default_lexicon())


@lru_cache(maxsize=64)
def _scene_words(commands: tuple[Any, ...], lex: Lexicon) -> frozenset[str]:
    out: set[str] = set()
    for c in commands:
        for text, _lp in content_prior(c, lex):
            out.update(w for w in normalize_text(text) if w not in FILLER_WORDS and w not in NUMBER_WORDS)
    return frozenset(out)


def chance_threshold(n_phones: int, table: dict[int, float] | None = None) -> float:
    """t for a heard word of ``n_phones`` phonemes (the nearest measured length outside the table);
    ``table``: :data:`CHANCE_R` (against a whole scene) unless given."""
    levels = CHANCE_R if table is None else table
    if not levels:
        return 0.0
    keys = sorted(levels)
    return levels[min(max(n_phones, keys[0]), keys[-1])]


_VOCABS: OrderedDict[frozenset[str], MeaningVocabulary] = OrderedDict()


def _vocab(words: frozenset[str]) -> MeaningVocabulary:
    v = _VOCABS.get(words)
    if v is None:
        v = _VOCABS[words] = MeaningVocabulary(words)
        if len(_VOCABS) > 256:  # one per scene and one per object class of the scenes in use
            _VOCABS.popitem(last=False)
    return v


def word_costs(text: str, words: frozenset[str]) -> list[tuple[str, int, float]]:
    """(heard word or pair, phonemes, r) for each non-filler word and adjacent non-filler pair."""
    voc = _vocab(words)
    heard = [w for w in normalize_text(text)]
    out = []
    for i, w in enumerate(heard):
        if w in FILLER_WORDS or w in NUMBER_WORDS:
            continue
        out.append((w, len(word_phonemes(w)), voc.relative_cost(w)))
        if i + 1 < len(heard) and heard[i + 1] not in FILLER_WORDS and heard[i + 1] not in NUMBER_WORDS:
            phones = word_phonemes(w) + word_phonemes(heard[i + 1])
            out.append((f"{w} {heard[i + 1]}", len(phones), voc.relative_cost_phones(phones, PAIR_EDGE)))
    return out


def heard_weights(nbest: Sequence[Any], temperature: float = ASR_TEMPERATURE,
                  min_weight: float = MIN_WEIGHT) -> list[tuple[str, float]]:
    """The N-best hypotheses (objects with ``text`` and ``score``) that carry at least
    ``min_weight`` of the weight softmax(score / temperature), with their weights renormalised:
    what was heard, not what the decoder could also have fitted."""
    hyps = [h for h in nbest if h.text.strip()]
    if not hyps:
        return []
    s = np.array([float(h.score) for h in hyps]) / temperature
    w = np.exp(s - s.max())
    w /= w.sum()
    floor = min(min_weight, float(w.max()))  # many equal hypotheses each weigh under the floor: keep the best
    kept = [(h.text, float(wk)) for h, wk in zip(hyps, w, strict=True) if wk >= floor]
    total = sum(wk for _, wk in kept)
    return [(t, wk / total) for t, wk in kept]


def heard_texts(nbest: Sequence[Any], temperature: float = ASR_TEMPERATURE,
                min_weight: float = MIN_WEIGHT) -> list[str]:
    """The texts of :func:`heard_weights`."""
    return [t for t, _ in heard_weights(nbest, temperature, min_weight)]
