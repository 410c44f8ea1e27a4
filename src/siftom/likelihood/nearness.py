"""Is anything that was heard near a command of this scene? Words alone are not an instruction.

A recogniser biased to a home's phrasings turns a cat's meow or a crackling fire into words
("hand", "the panel of"), and the noisy channel then finds *some* command most likely. Before
the robot acts on words it checks that some part of them sounds like a command of the scene:

    near(h) = min over heard words w (and adjacent pairs run together) of r(w) <= t(|w|)

with r the relative phoneme cost of :class:`~siftom.likelihood.background.MeaningVocabulary`
(0 for an exact command word, ~1 for nothing alike) against the content words of the scene's
commands (object names, synonyms, category words; counts alone name no command), and t the
chance level: the 1st percentile of r that random English words reach against the commands
of the built-in scenes, per word length in phonemes (``python -m siftom.bench.nearness``
measures it; docs/speech.md). So a heard word counts as near when it matches a command better
than 99 % of random words would.

A request is an instruction even when its object word was misheard: a hypothesis that holds a
request frame ("pass me ...", "could you bring ...", "can I have ...", "I need ...") followed by
a content word is near (``request_frame``); the actions then say which command it was, as in
the paper's "pass me the silver". Room talk and off-topic speech ("need an", "the weather is
nice today") hold no frame and no command word.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from siftom.likelihood.background import MeaningVocabulary
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phonemes import normalize_text, word_phonemes
from siftom.likelihood.phrasing import FILLER_WORDS, NUMBER_WORDS, content_prior

# t(length in phonemes): the 1st percentile of r for random cmudict words (seed 0, 4000 words)
# against the commands of every built-in scene; `python -m siftom.bench.nearness` (docs/speech.md)
CHANCE_R: dict[int, float] = {2: 0.076, 3: 0.181, 4: 0.147, 5: 0.21, 6: 0.256, 7: 0.35, 8: 0.406}
CHANCE_QUANTILE = 0.01
# t'(length): the 5th percentile of r for random cmudict words against the words of ONE object
# class (seed 5, 600 words x the built-in lexicon's classes): a heard word nearer than that to a
# command "could be" that command's word misheard (`python -m siftom.bench.nearness --per-command`)
COMMAND_CHANCE_R: dict[int, float] = {3: 0.536, 4: 0.537, 5: 0.496, 6: 0.513, 7: 0.54, 8: 0.581}
COMMAND_CHANCE_QUANTILE = 0.05
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


@dataclass(frozen=True)
class Nearness:
    """The heard word closest to a command of the scene, its relative cost and the chance level."""

    near: bool
    word: str
    cost: float
    threshold: float

    def reason(self) -> str:
        """One line for ``evidence``: why the words are not an instruction."""
        if not self.word:
            return "no word was heard beyond filler words"
        return (f"no heard word is near a command of this scene: the closest, {self.word!r}, is at relative "
                f"cost {self.cost:.2f}, worse than the {self.threshold:.2f} random words reach "
                f"{CHANCE_QUANTILE:.0%} of the time")


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


def heard_texts(nbest: Sequence[Any], temperature: float = ASR_TEMPERATURE,
                min_weight: float = MIN_WEIGHT) -> list[str]:
    """The N-best hypotheses (objects with ``text`` and ``score``) that carry at least
    ``min_weight`` of the weight softmax(score / temperature): what was heard, not what the
    decoder could also have fitted."""
    hyps = [h for h in nbest if h.text]
    if not hyps:
        return []
    s = np.array([float(h.score) for h in hyps]) / temperature
    w = np.exp(s - s.max())
    w /= w.sum()
    return [h.text for h, wk in zip(hyps, w, strict=True) if wk >= min_weight]


# the verbs of a request for an object, and the modal openings of a polite one
REQUEST_VERBS = frozenset(["bring", "get", "grab", "pass", "hand", "give", "fetch", "find", "take"])
_MODALS = frozenset(["can", "could", "would", "will"])
_WANTS = frozenset(["need", "want", "like"])


def request_frame(text: str) -> str:
    """The request frame in ``text`` followed by a content word, or '' (module doc).

    Frames: a request verb before "me"/"us" ("pass me"); a modal, "you"/"I" and a request verb
    or "have" ("could you bring", "can I have"); "I"/"we" and need/want/like ("I need",
    "I'd like"). The frame must be followed by a word that is neither a filler nor a number
    (the object, however misheard)."""
    ws = normalize_text(text)
    for i, w in enumerate(ws):
        end = -1
        if w in REQUEST_VERBS and i + 1 < len(ws) and ws[i + 1] in ("me", "us"):
            end = i + 2
        elif w in _MODALS and i + 2 < len(ws) and ws[i + 1] in ("you", "i", "we"):
            j = i + 2 + (ws[i + 2] == "please" and i + 3 < len(ws))
            if ws[j] in REQUEST_VERBS or ws[j] == "have":
                end = j + 1
        elif w in ("i", "we", "i'd", "we'd") and i + 1 < len(ws):
            j = i + 1 + (ws[i + 1] in ("would", "really", "still", "do") and i + 2 < len(ws))
            if ws[j] in _WANTS or (w in ("i'd", "we'd") and ws[i + 1] == "like"):
                end = j + 1
        if end > 0 and any(x not in FILLER_WORDS and x not in NUMBER_WORDS for x in ws[end:]):
            return " ".join(ws[i:end])
    return ""


def nearness(texts: Sequence[str], commands: Sequence[Any], lexicon: Lexicon | None = None) -> Nearness:
    """Whether any heard word (in any hypothesis) is near a command of ``commands``, or a
    hypothesis holds a request frame (module doc)."""
    words = scene_words(commands, lexicon)
    best = Nearness(False, "", float("inf"), 0.0)
    margin = float("inf")
    for text in texts:
        for w, n, r in word_costs(text, words):
            t = chance_threshold(n)
            if r - t < margin:
                margin, best = r - t, Nearness(r <= t, w, r, t)
    if not best.near:
        for text in texts:
            frame = request_frame(text)
            if frame:
                return Nearness(True, frame, best.cost, best.threshold)
    return best


def named_instead(texts: Sequence[str], command: Any, others: Sequence[Any],
                  lexicon: Lexicon | None = None) -> tuple[str, Any] | None:
    """(heard word, other command) when no heard word is near ``command``'s own words but one is
    near another of ``others`` (a class of the scene, wanted or not); None otherwise.

    The check before the robot acts: "pass the milk" when the milk is already on the counter
    must not become ``fetch(oatmeal)`` because the actions favour the oatmeal. Words near no
    object at all ("could you get me the ..." with the object lost) say nothing against the
    command, and neither does a misheard word that could be its word ("silver" for "cereal",
    "potato" for "tomato": nearer to it than 95 % of random words, :data:`COMMAND_CHANCE_R`).
    Naming another object is the no-instruction check's test against that object's words (no
    worse than random words reach 1 % of the time).
    """
    own = scene_words([command], lexicon)
    for text in texts:
        for _w, n, r in word_costs(text, own):
            if r <= chance_threshold(n, COMMAND_CHANCE_R):
                return None
    best: tuple[str, Any] | None = None
    margin = float("inf")
    for other in others:
        if getattr(other, "obj_class", None) == getattr(command, "obj_class", None):
            continue
        words = scene_words([other], lexicon)
        if own >= words:  # a word of both (a shared synonym or category) says nothing against it
            continue
        for text in texts:
            for w, n, r in word_costs(text, words - own):
                t = chance_threshold(n)
                if r <= t and r - t < margin:
                    margin, best = r - t, (w, other)
    return best
