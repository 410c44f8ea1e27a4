"""Which heard words could carry meaning: a background (garbage) model for the noisy channel.

People say much more than the object ("um could you get the milk from the fridge for me").
A heard word that sounds like no object name, synonym, category word or count cannot tell
one command from another, so the phonetic channel should pay the same for it under every
command instead of aligning it as if it were part of an object name ("breakfast" as "bread").

:class:`MeaningVocabulary` holds the phonemes of every word that can carry meaning (the
lexicon's names, synonyms and category words, number words, and the content words of any
phrasing scored so far) and gives each heard word a *relevance* g in [0, 1]:

    r(w) = min over meaning words v, over spans v[i:j] of v:
               [D(v[i:j], w) + β · (D(v[:i], ∅) + D(v[j:], ∅))] / D(∅, w)

the cheapest way to explain w's phonemes as (part of) a meaning word, relative to not
explaining them at all (D the weighted phoneme edit distance of ``phonetic.py``; a span
rather than the whole word, the unheard rest of the word costing β = 0.5 of its deletion
cost). g(w) is 1 for r <= r_near, 0 for r >= r_far and linear in between. A meaning word the
recogniser split in two ("see real" for "cereal") is caught by also rating each pair of
adjacent non-filler heard words that are not meaning words themselves, run together, against
whole meaning words (β = 1); a word gets the larger of its own and its pairs' relevance. The channel then treats w as
g · content + (1 − g) · background (docs/likelihoods.md).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from siftom.likelihood.lexicon import Lexicon
from siftom.likelihood.phrasing import FILLER_WORDS, NUMBER_WORDS

R_NEAR = 0.2
R_FAR = 0.4
EDGE_WEIGHT = 0.5


def lexicon_words(lexicon: Lexicon) -> set[str]:
    """Every word of every name, synonym and category word of ``lexicon``, and number words."""
    words: set[str] = set(NUMBER_WORDS[1:])
    d = lexicon.to_dict()
    for cid, entry in d.get("classes", {}).items():
        words.update(cid.replace("_", " ").split())
        for key in ("singular", "plural"):
            if isinstance(entry.get(key), str):
                words.update(entry[key].split())
        for syn in entry.get("synonyms", []):
            for s in [syn] if isinstance(syn, str) else syn:
                words.update(s.split())
    for cat in d.get("categories", {}):
        words.update(cat.split())
    for cid in lexicon_class_ids(lexicon):
        e = lexicon.entry(cid)
        for name in e.names:
            words.update(name.singular.split())
            words.update(name.plural.split())
    return {w for w in words if w and w not in FILLER_WORDS}


def lexicon_class_ids(lexicon: Lexicon) -> list[str]:
    """Class ids listed in the lexicon."""
    return list(lexicon.to_dict().get("classes", {}))


class MeaningVocabulary:
    """Phonemes of the words that can carry meaning; relevance of heard words (cached).

    Args:
        words: the initial meaning words (see :func:`lexicon_words`).
        r_near: relative cost at or below which a heard word counts as fully relevant.
        r_far: relative cost at or above which it is background.
    """

    def __init__(self, words: Iterable[str], r_near: float = R_NEAR, r_far: float = R_FAR,
                 edge_weight: float = EDGE_WEIGHT) -> None:
        if not 0 <= r_near < r_far:
            raise ValueError(f"need 0 <= r_near < r_far, got {r_near}, {r_far}")
        self.r_near = float(r_near)
        self.r_far = float(r_far)
        self.edge_weight = float(edge_weight)
        self.words: set[str] = set()
        self._ids = np.zeros((0, 1), dtype=np.intp)
        self._ins = np.zeros((0, 1), dtype=np.float32)
        self._cache: dict[str, float] = {}
        self.order: tuple[str, ...] = ()
        self.add(words)

    def add(self, words: Iterable[str]) -> bool:
        """Add meaning words; True when any was new (cached relevances are then dropped)."""
        from siftom.likelihood.phonemes import PAD, PHONEME_ID, indel_cost, word_phonemes

        new = sorted({w for w in words if w and w not in FILLER_WORDS} - self.words)
        if not new:
            return False
        self.words.update(new)
        pairs = [(w, word_phonemes(w)) for w in sorted(self.words)]
        pairs = [(w, s) for w, s in pairs if s]
        self.order = tuple(w for w, _ in pairs)  # the meaning word of each row
        seqs = [s for _, s in pairs]
        width = max((len(s) for s in seqs), default=1)
        self._ids = np.full((len(seqs), width), PAD, dtype=np.intp)
        self._ins = np.zeros((len(seqs), width), dtype=np.float32)
        for k, s in enumerate(seqs):
            self._ids[k, : len(s)] = [PHONEME_ID[p] for p in s]
            self._ins[k, : len(s)] = [indel_cost(p) for p in s]
        self._cache.clear()
        return True

    def relative_cost(self, word: str) -> float:
        """r(w): cheapest explanation of ``word`` as a span of a meaning word / not explaining it."""
        from siftom.likelihood.phonemes import word_phonemes

        if word in self.words:
            return 0.0
        return self.relative_cost_phones(word_phonemes(word))

    def relative_cost_phones(self, phones: tuple[str, ...], edge_weight: float | None = None) -> float:
        """r for a phoneme sequence (a word, or two adjacent heard words run together); the
        unheard rest of the meaning word costs ``edge_weight`` (default: the instance's β)."""
        if not phones:
            return 0.0
        if len(self._ids) == 0:
            return float("inf")
        return float(self.relative_costs_phones(phones, edge_weight).min())

    def relative_costs_phones(self, phones: tuple[str, ...], edge_weight: float | None = None) -> np.ndarray:
        """r of a phoneme sequence against each meaning word (in :attr:`order`)."""
        from siftom.likelihood.phonemes import PHONEME_ID, SUB_COST, indel_cost

        n_v, width = self._ids.shape
        if not phones or n_v == 0:
            return np.zeros(n_v) if not phones else np.full(n_v, np.inf)
        # Every phoneme of the heard word is explained; the meaning word's phonemes before and
        # after the matched span cost edge_weight x their deletion cost (a heard fragment of a
        # long word is weaker evidence than the whole word).
        beta = self.edge_weight if edge_weight is None else edge_weight
        cum = np.zeros((n_v, width + 1), dtype=np.float32)
        np.cumsum(self._ins, axis=1, out=cum[:, 1:])
        prev = beta * cum
        for p in phones:
            pid = PHONEME_ID[p]
            dp = indel_cost(p)
            cur = np.empty_like(prev)
            cur[:, 0] = prev[:, 0] + dp
            diag = prev[:, :-1] + SUB_COST[pid, self._ids]
            vert = prev[:, 1:] + dp
            best = np.minimum(diag, vert)
            for j in range(width):
                cur[:, j + 1] = np.minimum(best[:, j], cur[:, j] + self._ins[:, j])
            prev = cur
        end = prev + beta * (cum[:, -1:] - cum)
        total = sum(indel_cost(p) for p in phones)
        out: np.ndarray = end.min(axis=1) / total if total > 0 else np.zeros(n_v)
        return out

    def _ramp(self, r: float) -> float:
        return float(np.clip((self.r_far - r) / (self.r_far - self.r_near), 0.0, 1.0))

    def relevance(self, word: str) -> float:
        """g(w) in [0, 1]: 1 when ``word`` sounds like (part of) a meaning word, 0 when like none."""
        g = self._cache.get(word)
        if g is None:
            g = self._cache[word] = self._ramp(self.relative_cost(word))
        return g

    def pair_relevance(self, first: str, second: str) -> float:
        """g of two adjacent heard words run together: a recogniser can split one meaning word
        into two ("see real" for "cereal"); each of the two words gets at least this relevance.
        The pair must sound like a *whole* meaning word (its unheard rest costs full deletion),
        so two ordinary words that share a fragment with a name ("as well", "lettuce") do not."""
        from siftom.likelihood.phonemes import word_phonemes

        key = first + " " + second
        g = self._cache.get(key)
        if g is None:
            phones = word_phonemes(first) + word_phonemes(second)
            g = self._cache[key] = self._ramp(self.relative_cost_phones(phones, edge_weight=1.0))
        return g
