"""The default instruction likelihood: a phonetic noisy channel over N-best transcripts.

:class:`PhoneticLikelihood` combines the phoneme costs of :mod:`siftom.likelihood.phonemes`,
the edit distance of :mod:`siftom.likelihood.editdistance`, the background model of
:mod:`siftom.likelihood.background` and the phrasings of ``phrasing.py`` (paper, Methods,
Instruction Likelihood; the equation is in docs/likelihoods.md).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from siftom.errors import ObservationError
from siftom.language.understand import SLOT_SHARPNESS, Namer, namer
from siftom.likelihood.background import R_FAR, R_NEAR, MeaningVocabulary, lexicon_words
from siftom.likelihood.base import Scores
from siftom.likelihood.editdistance import (
    PhonemeTrie,
    encode,
    trie_edit_distance,
)
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phonemes import (
    _STOPS,
    FINAL_STOP_DISCOUNT,
    PHONEME_ID,
    _normalize,
    indel_cost,
    normalize_text,
    word_phonemes,
)
from siftom.likelihood.phrasing import FILLER_WORDS, content_prior
from siftom.logspace import logsumexp
from siftom.memo import Memo, memo
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand


@dataclass(frozen=True, eq=False)
class _Plan:
    """What scoring a tuple of commands needs, built once per (configuration, commands)."""

    contents: tuple[str, ...]  # the content words ("three forks") of the commands' phrasings
    index: np.ndarray  # (n_commands, K) positions into contents
    log_prior: np.ndarray  # (n_commands, K), -inf on padding
    trie: PhonemeTrie  # the contents' phonemes, in order
    vocab: MeaningVocabulary  # rates the heard words (the lexicon's words and these contents')
    vocab_key: frozenset[str]
    lost: np.ndarray  # D(nothing, u) per content: the cost of deleting it
    token: int  # unique per plan: the key of its distance rows


_TOKENS = itertools.count()


@lru_cache(maxsize=256)
def _namer_of(lexicon: Lexicon, classes: tuple[str, ...]) -> Namer:
    """The utterance model's namer of the lexicon's classes and ``classes`` (kept: one per scene)."""
    return namer(tuple(sorted(set(lexicon.classes) | set(classes))), lexicon)
# the memos of every phonetic likelihood (keyed by its configuration: siftom.memo)
_PLANS: Memo[_Plan] = memo("phonetic.plans", 256)
_CONTENTS: Memo[tuple[np.ndarray, np.ndarray]] = memo("phonetic.contents", 65536)
_VOCABS: Memo[MeaningVocabulary] = memo("phonetic.vocabularies", 64)
_HEARD: Memo[tuple[np.ndarray, np.ndarray, np.ndarray]] = memo("phonetic.heard", 16384)
_DISTANCES: Memo[np.ndarray] = memo("phonetic.distances", 16384)


def _encode_content(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Phoneme codes and deletion costs of a content ("three forks")."""
    phones: list[str] = []
    costs: list[float] = []
    for w in normalize_text(text):
        wp = word_phonemes(w)
        phones.extend(wp)
        costs.extend(indel_cost(p) for p in wp)
        if wp and wp[-1] in _STOPS:
            # Word-final stops are often unreleased and lost ("milk" heard "mail").
            costs[-1] *= FINAL_STOP_DISCOUNT
    return encode(phones), np.array(costs, dtype=np.float32)


class PhoneticLikelihood:
    r"""Noisy channel over N-best transcripts and phrasings (paper, Methods, Instruction Likelihood).

    .. math::

        P(\phi \mid \pi_r) = \sum_u P(u \mid \pi_r) \sum_n w_n \, e^{-\lambda D(h_n, u)},
        \qquad w_n = \operatorname{softmax}_n(s_n / T_{asr})

    ``u`` ranges over the phrasings of the command (``phrasing.py``), ``h_n`` over the N-best
    hypotheses with log scores ``s_n``. ``D`` is a weighted phoneme edit distance from the
    phrasing's content words ("three forks") to the whole hypothesis, where hypothesis phonemes
    of filler words ("can you pass me the") cost ``filler_cost`` to skip and those of other
    words cost their full insertion cost, so the alignment concentrates on the object words but
    still pays for hypothesis words it cannot explain. Substitutions are cheaper between similar
    phonemes (vowel/vowel, voiced/unvoiced pairs, nasals, liquids). The normaliser of
    ``P(h | u)`` is taken as the same for all phrasings, so only differences between commands
    are meaningful (as for every instruction likelihood).

    Args:
        lexicon: names of the classes (default :func:`default_lexicon`).
        lam: lambda, nats per unit of edit cost (one consonant error costs about 0.85).
        asr_temperature: T_asr, divides the N-best log scores before the softmax; larger
            trusts the ranking less. Equal scores give equal weights.
        filler_cost: cost per phoneme of skipping a filler word of the hypothesis.
        filler_sub_penalty: added to the cost of aligning a content phoneme onto a filler
            word's phoneme (a content word misheard as "the" or "me" is possible but rare).
        content_insert_scale: multiplies the insertion cost of non-filler hypothesis phonemes.
    """

    name = "phonetic"
    needs_text = True
    needs_audio = False

    def __init__(
        self,
        lexicon: Lexicon | None = None,
        *,
        lam: float = 2.0,
        asr_temperature: float = 10.0,
        filler_cost: float = 0.15,
        filler_sub_penalty: float = 0.4,
        content_insert_scale: float = 0.5,
        lost_word_weight: float = 0.3,
        slot_sharpness: float = SLOT_SHARPNESS,
        background: bool = True,
        relevance_range: tuple[float, float] = (R_NEAR, R_FAR),
        cache_size: int = 4096,
    ) -> None:
        for label, v in (("lam", lam), ("asr_temperature", asr_temperature),
                         ("content_insert_scale", content_insert_scale)):
            if not (np.isfinite(v) and v > 0):
                raise ObservationError(f"{label} must be a positive number, got {v!r}")
        for label, v in (("filler_cost", filler_cost), ("filler_sub_penalty", filler_sub_penalty)):
            if not (np.isfinite(v) and v >= 0):
                raise ObservationError(f"{label} must be a number >= 0, got {v!r}")
        self.lexicon = lexicon or default_lexicon()
        self.lam = float(lam)
        self.asr_temperature = float(asr_temperature)
        self.filler_cost = float(filler_cost)
        self.filler_sub_penalty = float(filler_sub_penalty)
        self.content_insert_scale = float(content_insert_scale)
        # Noise can mask the object word entirely. Scoring D(h, u) - D(nothing, u), a likelihood
        # ratio against "the words were lost", keeps short words from winning just because
        # deleting fewer phonemes costs less (docs/likelihoods.md).
        if not (np.isfinite(lost_word_weight) and 0 <= lost_word_weight <= 1):
            raise ObservationError(f"lost_word_weight must be in [0, 1], got {lost_word_weight!r}")
        self.lost_word_weight = float(lost_word_weight)
        # The slot channel: the target slot's words speak against each object by how unlike its
        # names they sound (siftom.language.understand.slot_log_factor); 0 turns it off
        if not (np.isfinite(slot_sharpness) and slot_sharpness >= 0):
            raise ObservationError(f"slot_sharpness must be a number >= 0, got {slot_sharpness!r}")
        self.slot_sharpness = float(slot_sharpness)
        # Words that sound like no object name, synonym, category word or count are background:
        # they cost about the same under every command (background.py, docs/likelihoods.md).
        self.background = bool(background)
        r_near, r_far = relevance_range
        if not (np.isfinite(r_near) and np.isfinite(r_far) and 0 <= r_near < r_far):
            raise ObservationError(f"relevance_range must be (near, far) with 0 <= near < far, got {relevance_range!r}")
        self.relevance_range = (float(r_near), float(r_far))
        self._lexicon_words = frozenset(lexicon_words(self.lexicon))
        self.cache_size = int(cache_size)  # kept for callers; the memos are bounded (siftom.memo)
        # everything a memoised value depends on: one key per configuration
        self._key = (self.lexicon.fingerprint, self.background, self.relevance_range, self.filler_cost,
                     self.filler_sub_penalty, self.content_insert_scale)

    # -- encoding ------------------------------------------------------------------------------

    def vocabulary(self, commands: Sequence[RobotCommand]) -> MeaningVocabulary:
        """The meaning words that rate heard words when scoring ``commands``."""
        return self._plan(tuple(commands)).vocab

    def _vocab_for(self, contents: Iterable[str]) -> tuple[frozenset[str], MeaningVocabulary]:
        key = frozenset(self._lexicon_words | {w for c in contents for w in normalize_text(c)})
        return key, _VOCABS.get((key, self.relevance_range), lambda: MeaningVocabulary(key, *self.relevance_range))

    def _heard(self, text: str, plan: _Plan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Phoneme ids, insertion costs and substitution penalties of a hypothesis (memoised)."""
        return _HEARD.get((self._key, plan.vocab_key, text), lambda: self._encode_heard(text, plan.vocab))

    def _encode_heard(self, text: str, vocab: MeaningVocabulary) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ids: list[int] = []
        ins: list[float] = []
        sub: list[float] = []
        words = normalize_text(text)
        for w, g in zip(words, self._relevances(words, vocab), strict=True):
            for p in word_phonemes(w):
                ids.append(PHONEME_ID[p])
                ins.append(g * indel_cost(p) * self.content_insert_scale + (1 - g) * self.filler_cost)
                sub.append((1 - g) * self.filler_sub_penalty)
        return (np.array(ids, dtype=np.int16), np.array(ins, dtype=np.float32),
                np.array(sub, dtype=np.float32))

    def _relevances(self, words: Sequence[str], vocab: MeaningVocabulary) -> list[float]:
        """g per heard word: 0 for filler words, else how much it sounds like a meaning word,
        alone or run together with a non-filler neighbour when neither is one already ("see
        real" for "cereal", but not "egg as" for "eggs"); 1 without the background model."""
        if not self.background:
            return [0.0 if w in FILLER_WORDS else 1.0 for w in words]
        voc = vocab
        g = [0.0 if w in FILLER_WORDS else voc.relevance(w) for w in words]
        for i in range(len(words) - 1):
            a, b = words[i], words[i + 1]
            if a not in FILLER_WORDS and b not in FILLER_WORDS and max(g[i], g[i + 1]) < 1.0:
                pg = voc.pair_relevance(a, b)
                g[i], g[i + 1] = max(g[i], pg), max(g[i + 1], pg)
        return g

    def _plan(self, commands: tuple[RobotCommand, ...]) -> _Plan:
        return _PLANS.get((self._key, commands), lambda: self._make_plan(commands))

    def _make_plan(self, commands: tuple[RobotCommand, ...]) -> _Plan:
        per_cmd = [content_prior(c, self.lexicon) for c in commands]
        used: dict[str, int] = {}
        k = max((len(p) for p in per_cmd), default=1)
        index = np.zeros((len(commands), k), dtype=np.intp)
        prior = np.full((len(commands), k), -np.inf)
        for r, pairs in enumerate(per_cmd):
            for c, (text, lp) in enumerate(pairs):
                index[r, c] = used.setdefault(text, len(used))
                prior[r, c] = lp
        contents = tuple(used)
        said = [_CONTENTS.get(t, lambda t=t: _encode_content(t)) for t in contents]  # type: ignore[misc]
        vocab_key, vocab = self._vocab_for(contents)
        lost = np.array([float(costs.sum()) for _, costs in said])
        return _Plan(contents, index, prior, PhonemeTrie.build(said), vocab, vocab_key, lost, next(_TOKENS))

    # -- distances -----------------------------------------------------------------------------

    def distances(self, texts: Sequence[str], plan: _Plan) -> np.ndarray:
        """D(h, u) for each hypothesis text and each content of ``plan``: (n_contents, n_texts).

        Rows are memoised per plan and hypothesis text, so re-scoring an instruction is a lookup.
        """
        out = np.empty((len(plan.contents), len(texts)), dtype=np.float32)
        todo: list[int] = []
        for j, t in enumerate(texts):
            col = _DISTANCES.peek((plan.token, t))
            if col is None:
                todo.append(j)
            else:
                out[:, j] = col
        if todo:  # the missing rows in one batch
            heard = [self._heard(texts[j], plan) for j in todo]
            nonempty = [k for k, h in enumerate(heard) if len(h[0])]
            block = np.zeros((len(plan.contents), len(todo)), dtype=np.float32)
            if nonempty:
                block[:, nonempty] = trie_edit_distance(plan.trie, [heard[k] for k in nonempty])
            for k, j in enumerate(todo):
                col = block[:, k].copy()
                col.setflags(write=False)
                out[:, j] = _DISTANCES.put((plan.token, texts[j]), col)
        return out

    # -- the likelihood ------------------------------------------------------------------------

    def nbest_weights(self, instruction: Instruction, classes: Iterable[str] = ()) -> tuple[list[str], np.ndarray]:
        """Distinct hypothesis texts and their log weights log w_n (duplicates merged), each read
        by the utterance model: only the words that ask for the target(s) of ``instruction.focus``
        (the request frame and the target slots; negated, taken-back and context objects are
        background, siftom.language)."""
        from siftom.language.understand import focus_text

        nm = _namer_of(self.lexicon, tuple(classes))
        scores = np.array([h.score for h in instruction.nbest], dtype=float) / self.asr_temperature
        logw = scores - logsumexp(scores)
        merged: dict[str, float] = {}
        for h, lw in zip(instruction.nbest, logw, strict=True):
            key = " ".join(_normalize(focus_text(h.text, instruction.focus, nm)))
            merged[key] = float(np.logaddexp(merged[key], lw)) if key in merged else float(lw)
        return list(merged), np.array(list(merged.values()))

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> Scores:
        """log P(phi | pi_r) for each command; shape (len(commands),)."""
        if not instruction.nbest:
            raise ObservationError(
                "the phonetic likelihood needs a transcript or an N-best list; transcribe the "
                "audio first or use the 'acoustic' likelihood"
            )
        commands = tuple(commands)
        if not commands:
            return Scores(np.zeros(0))
        plan = self._plan(commands)
        texts, logw = self.nbest_weights(instruction, (c.obj_class for c in commands))
        d = self.distances(texts, plan)  # (n_contents, n_hyps)
        ch = self._channel(d, plan)
        ch[:, [len(self._heard(t, plan)[0]) == 0 for t in texts]] = 0.0  # nothing heard: uninformative
        per_content = logsumexp(logw[None, :] + ch, axis=1)
        out = logsumexp(plan.log_prior + per_content[plan.index], axis=1)
        if self.slot_sharpness > 0:
            from siftom.language.understand import SCENE_WORDS_WEIGHT, SLOT_CAP, slot_log_factor

            k = SCENE_WORDS_WEIGHT if instruction.scene_words else 1.0
            out = out + slot_log_factor(texts, np.exp(logw), commands, self.lexicon, instruction.focus,
                                        self.slot_sharpness * k, SLOT_CAP * k)
        return Scores(out)

    def _channel(self, d: np.ndarray, plan: _Plan) -> np.ndarray:
        """-lam (D(h, u) - alpha D(nothing, u)) per content and hypothesis (alpha = lost_word_weight)."""
        lp = -self.lam * d.astype(float)
        if self.lost_word_weight > 0:
            lp += (self.lam * self.lost_word_weight) * plan.lost[:, None]
        return lp

    def explain(self, instruction: Instruction, command: RobotCommand) -> list[tuple[str, float]]:
        """(content words, log prior + log channel) for a command's phrasings, best first."""
        plan = self._plan((command,))
        texts, logw = self.nbest_weights(instruction)
        d = self.distances(texts, plan)
        per_content = logsumexp(logw[None, :] + self._channel(d, plan), axis=1)
        rows = [(plan.contents[i], float(lp + per_content[i]))
                for i, lp in zip(plan.index[0], plan.log_prior[0], strict=True) if np.isfinite(lp)]
        return sorted(rows, key=lambda r: -r[1])
