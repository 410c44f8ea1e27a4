"""The default instruction likelihood: a phonetic noisy channel over N-best transcripts.

The file has three parts: words to ARPAbet phonemes and how far apart two phonemes sound; a
vectorised weighted edit distance; and :class:`PhoneticLikelihood`, which combines them with
the phrasings of ``phrasing.py`` (paper, Methods, Instruction Likelihood).

Pronunciations come from the CMUdict that pocketsphinx ships (the recogniser's own
vocabulary, so every word it outputs is there). Unknown words (typed transcripts, new class
names) go through espeak-ng's IPA output mapped onto ARPAbet, and, when espeak-ng is absent,
through a letter-to-sound table. All lookups are cached per process.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from siftom.errors import ObservationError
from siftom.likelihood.background import R_FAR, R_NEAR, MeaningVocabulary, lexicon_words
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phrasing import FILLER_WORDS, content_prior, number_word
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

VOWELS = ("AA", "AE", "AH", "AO", "AW", "AY", "EH", "ER", "EY", "IH", "IY", "OW", "OY", "UH", "UW")
CONSONANTS = (
    "B", "CH", "D", "DH", "F", "G", "HH", "JH", "K", "L", "M", "N", "NG", "P", "R", "S", "SH",
    "T", "TH", "V", "W", "Y", "Z", "ZH",
)
PHONEMES: tuple[str, ...] = VOWELS + CONSONANTS
PHONEME_ID = {p: i for i, p in enumerate(PHONEMES)}
PAD = len(PHONEMES)  # index of the padding symbol in cost tables
_VOWEL_SET = frozenset(VOWELS)

# Consonant features: place (ordered front to back), manner, voiced.
_PLACE = {"bilabial": 0, "labiodental": 1, "dental": 2, "alveolar": 3, "postalveolar": 4,
          "palatal": 5, "velar": 6, "glottal": 7}
_CONS = {
    "P": ("bilabial", "stop", 0), "B": ("bilabial", "stop", 1), "M": ("bilabial", "nasal", 1),
    "F": ("labiodental", "fricative", 0), "V": ("labiodental", "fricative", 1),
    "TH": ("dental", "fricative", 0), "DH": ("dental", "fricative", 1),
    "T": ("alveolar", "stop", 0), "D": ("alveolar", "stop", 1), "N": ("alveolar", "nasal", 1),
    "S": ("alveolar", "fricative", 0), "Z": ("alveolar", "fricative", 1),
    "L": ("alveolar", "lateral", 1), "R": ("postalveolar", "rhotic", 1),
    "SH": ("postalveolar", "fricative", 0), "ZH": ("postalveolar", "fricative", 1),
    "CH": ("postalveolar", "affricate", 0), "JH": ("postalveolar", "affricate", 1),
    "Y": ("palatal", "glide", 1), "K": ("velar", "stop", 0), "G": ("velar", "stop", 1),
    "NG": ("velar", "nasal", 1), "W": ("bilabial", "glide", 1), "HH": ("glottal", "fricative", 0),
}
# Manner distances: affricates sit between stops and fricatives; liquids and glides are close.
_MANNER_NEAR = {frozenset(p) for p in (("stop", "affricate"), ("fricative", "affricate"),
                                       ("lateral", "rhotic"), ("lateral", "glide"),
                                       ("rhotic", "glide"))}
# Vowels: (height 0 low .. 3 high, backness 0 front .. 2 back, rounded, r-coloured).
_VOW = {
    "IY": (3.0, 0.0, 0, 0), "IH": (2.5, 0.2, 0, 0), "EY": (2.2, 0.1, 0, 0), "EH": (1.5, 0.2, 0, 0),
    "AE": (0.6, 0.3, 0, 0), "AA": (0.0, 1.6, 0, 0), "AO": (0.7, 2.0, 1, 0), "OW": (1.8, 2.0, 1, 0),
    "UH": (2.5, 1.7, 1, 0), "UW": (3.0, 2.0, 1, 0), "AH": (1.2, 1.1, 0, 0), "ER": (1.5, 1.0, 0, 1),
    "AY": (0.8, 0.8, 0, 0), "AW": (0.8, 1.6, 1, 0), "OY": (1.2, 1.8, 1, 0),
}
# Phonemes that are easy to lose: reduced vowels and weak consonants cost less to delete.
_CHEAP_DELETE = {"AH": 0.45, "IH": 0.55, "ER": 0.6, "HH": 0.4, "D": 0.65, "T": 0.65, "Y": 0.6,
                 "W": 0.6, "R": 0.6, "L": 0.7}
_STOPS = frozenset(("P", "B", "T", "D", "K", "G"))
FINAL_STOP_DISCOUNT = 0.6
VOWEL_INDEL = 0.65
CONSONANT_INDEL = 0.85


def _consonant_cost(a: str, b: str) -> float:
    pa, ma, va = _CONS[a]
    pb, mb, vb = _CONS[b]
    cost = 0.0
    dplace = abs(_PLACE[pa] - _PLACE[pb])
    if dplace:
        cost += 0.2 if dplace == 1 else 0.35
    if ma != mb:
        cost += 0.2 if frozenset((ma, mb)) in _MANNER_NEAR else 0.45
    if va != vb:
        cost += 0.2
    # Dental fricatives are heard as labiodentals and alveolar stops (three/free/tree).
    if {a, b} in ({"TH", "F"}, {"DH", "V"}, {"TH", "T"}, {"DH", "D"}, {"S", "SH"}, {"Z", "ZH"}):
        cost = min(cost, 0.3)
    return min(cost, 1.0)


def _vowel_cost(a: str, b: str) -> float:
    ha, ba, ra, xa = _VOW[a]
    hb, bb, rb, xb = _VOW[b]
    cost = 0.15 + 0.08 * abs(ha - hb) + 0.1 * abs(ba - bb) + 0.05 * abs(ra - rb) + 0.2 * abs(xa - xb)
    return min(cost, 0.7)


def _raw_substitution_cost(a: str, b: str) -> float:
    if a == b:
        return 0.0
    va, vb = a in _VOWEL_SET, b in _VOWEL_SET
    if va and vb:
        return _vowel_cost(a, b)
    if not va and not vb:
        return _consonant_cost(a, b)
    pair = {a, b}
    if pair == {"ER", "R"}:
        return 0.35
    if pair in ({"IY", "Y"}, {"UW", "W"}):
        return 0.5
    return 1.0


def _raw_indel_cost(p: str) -> float:
    if p in _CHEAP_DELETE:
        return _CHEAP_DELETE[p]
    return VOWEL_INDEL if p in _VOWEL_SET else CONSONANT_INDEL


def _build_tables() -> tuple[np.ndarray, np.ndarray]:
    """Substitution and indel tables closed under shortest paths (Floyd-Warshall).

    The hand-set costs alone can break the triangle inequality (F->HH then delete HH could be
    cheaper than deleting F). Treating deletion as substitution by an empty symbol and taking
    the shortest path between every pair makes the edit distance a metric.
    """
    n = len(PHONEMES)
    m = np.zeros((n + 1, n + 1))
    for i, a in enumerate(PHONEMES):
        for j, b in enumerate(PHONEMES):
            m[i, j] = _raw_substitution_cost(a, b)
        m[i, n] = m[n, i] = _raw_indel_cost(a)
    for k in range(n + 1):
        m = np.minimum(m, m[:, k : k + 1] + m[k : k + 1, :])
    sub = np.full((n + 1, n + 1), 1e6, dtype=np.float32)
    sub[:n, :n] = m[:n, :n]
    indel = np.zeros(n + 1, dtype=np.float32)  # PAD costs nothing to skip
    indel[:n] = m[:n, n]
    return sub, indel


SUB_COST, INDEL_COST = _build_tables()


def substitution_cost(a: str, b: str) -> float:
    """Cost of hearing phoneme ``b`` where ``a`` was said; symmetric, 0 iff equal, at most 1."""
    return float(SUB_COST[PHONEME_ID[a], PHONEME_ID[b]])


def indel_cost(p: str) -> float:
    """Cost of a phoneme said but not heard (or heard but not said)."""
    return float(INDEL_COST[PHONEME_ID[p]])


# -- pronunciations ---------------------------------------------------------------------------


def cmudict_path() -> Path | None:
    """The CMUdict file inside the installed pocketsphinx package, or None."""
    try:
        import pocketsphinx
    except ImportError:  # pragma: no cover - pocketsphinx is a core dependency
        return None
    base = Path(pocketsphinx.__file__).parent
    for cand in (base / "model" / "en-us" / "cmudict-en-us.dict", *base.glob("model/**/*.dict")):
        if cand.is_file():
            return cand
    return None


def _split_er(phones: Iterable[str]) -> tuple[str, ...]:
    # ER is a schwa coloured by R; writing it AH R lets "silver" (..V ER) align with
    # "cereal" (..AH L) and "flour" (..AW ER) with "flower" (..AW AH R) phoneme by phoneme.
    out: list[str] = []
    for p in phones:
        out.extend(("AH", "R") if p == "ER" else (p,))
    return tuple(out)


@lru_cache(maxsize=1)
def cmudict() -> dict[str, tuple[str, ...]]:
    """word -> ARPAbet phonemes (first pronunciation, stress digits removed)."""
    path = cmudict_path()
    out: dict[str, tuple[str, ...]] = {}
    if path is None:
        return out
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            parts = line.split()
            if len(parts) < 2 or "(" in parts[0]:
                continue
            phones = _split_er(p.rstrip("012") for p in parts[1:])
            if all(p in PHONEME_ID for p in phones):
                out[parts[0]] = phones
    return out


_IPA_MULTI = {
    "aɪ": "AY", "aʊ": "AW", "eɪ": "EY", "oʊ": "OW", "əʊ": "OW", "ɔɪ": "OY", "tʃ": "CH",
    "dʒ": "JH", "ɜː": "ER", "iː": "IY", "uː": "UW", "ɑː": "AA", "ɔː": "AO", "ɪə": "IH",
    "eə": "EH", "ʊə": "UH", "ɑːɹ": "AA R",
}
_IPA_SINGLE = {
    "i": "IY", "ɪ": "IH", "e": "EH", "ɛ": "EH", "æ": "AE", "a": "AE", "ɑ": "AA", "ɒ": "AA",
    "ɔ": "AO", "o": "OW", "ʊ": "UH", "u": "UW", "ʌ": "AH", "ə": "AH", "ɐ": "AH", "ᵻ": "IH",
    "ɜ": "ER", "ɚ": "ER", "ɝ": "ER", "p": "P", "b": "B", "t": "T", "d": "D", "k": "K", "g": "G",
    "ɡ": "G", "f": "F", "v": "V", "θ": "TH", "ð": "DH", "s": "S", "z": "Z", "ʃ": "SH", "ʒ": "ZH",
    "h": "HH", "m": "M", "n": "N", "ŋ": "NG", "l": "L", "ɫ": "L", "ɹ": "R", "r": "R", "j": "Y",
    "w": "W", "ɾ": "T", "x": "K", "ç": "HH", "y": "UW",
}


def ipa_to_arpabet(ipa: str) -> tuple[str, ...]:
    """Map an IPA string (as espeak-ng writes it) onto ARPAbet; unknown marks are dropped."""
    out: list[str] = []
    s = ipa.strip()
    i = 0
    while i < len(s):
        for k in (3, 2):
            chunk = s[i : i + k]
            if chunk in _IPA_MULTI:
                out.extend(_IPA_MULTI[chunk].split())
                i += k
                break
        else:
            ph = _IPA_SINGLE.get(s[i])
            if ph:
                out.append(ph)
            i += 1
    return tuple(out)


_LETTER_MULTI = {"sh": "SH", "ch": "CH", "th": "TH", "ph": "F", "ng": "NG", "ck": "K",
                 "ee": "IY", "ea": "IY", "oo": "UW", "ou": "AW", "ai": "EY", "ay": "EY",
                 "oa": "OW", "qu": "K W", "gh": "", "wh": "W"}
_LETTER = {"a": "AE", "b": "B", "c": "K", "d": "D", "e": "EH", "f": "F", "g": "G", "h": "HH",
           "i": "IH", "j": "JH", "k": "K", "l": "L", "m": "M", "n": "N", "o": "AA", "p": "P",
           "q": "K", "r": "R", "s": "S", "t": "T", "u": "AH", "v": "V", "w": "W", "x": "K S",
           "y": "IY", "z": "Z"}


def letters_to_arpabet(word: str) -> tuple[str, ...]:
    """Crude letter-to-sound rules, the last resort when neither CMUdict nor espeak-ng knows."""
    w = re.sub(r"[^a-z]", "", word.lower())
    w = re.sub(r"([bcdfgklmnprstvz])\1", r"\1", w)
    if len(w) > 2 and w.endswith("e") and w[-2] not in "aeiou":
        w = w[:-1]  # silent final e
    out: list[str] = []
    i = 0
    while i < len(w):
        if w[i : i + 2] in _LETTER_MULTI:
            out.extend(_LETTER_MULTI[w[i : i + 2]].split())
            i += 2
            continue
        ph = _LETTER[w[i]]
        if w[i] == "y" and i == 0:
            ph = "Y"
        out.extend(ph.split())
        i += 1
    return tuple(out)


@lru_cache(maxsize=1)
def _espeak() -> str | None:
    return shutil.which("espeak-ng")


@lru_cache(maxsize=4096)
def espeak_phonemes(word: str) -> tuple[str, ...] | None:
    """ARPAbet phonemes from ``espeak-ng -q --ipa``, or None when espeak-ng is unavailable."""
    exe = _espeak()
    if exe is None:
        return None
    try:
        res = subprocess.run([exe, "-q", "--ipa", "-v", "en-us", word], capture_output=True,
                             text=True, timeout=5, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    if res.returncode != 0:
        return None
    phones = ipa_to_arpabet(res.stdout)
    return phones or None


@lru_cache(maxsize=65536)
def word_phonemes(word: str) -> tuple[str, ...]:
    """Phonemes of one lowercase word: CMUdict, then compound split, espeak-ng, letters."""
    d = cmudict()
    if word in d:
        return d[word]
    w = word.strip("'")
    if w in d:
        return d[w]
    if not w:
        return ()
    # Compounds such as "wineglass" or "cornflakes": two dictionary words.
    for k in range(3, len(w) - 2):
        if w[:k] in d and w[k:] in d:
            return d[w[:k]] + d[w[k:]]
    return _split_er(espeak_phonemes(w) or letters_to_arpabet(w))


_DIGITS_RE = re.compile(r"\d+")
_MARKUP_RE = re.compile(r"<[^>]*>|\[[^\]]*\]|\(\d+\)")


def normalize_text(text: str) -> list[str]:
    """Lowercase words; digits spelled out, ASR markup (<sil>, [NOISE], word(2)) removed."""
    return list(_normalize(text))


@lru_cache(maxsize=16384)
def _normalize(text: str) -> tuple[str, ...]:
    t = _MARKUP_RE.sub(" ", text.lower())
    t = _DIGITS_RE.sub(lambda m: f" {number_word(int(m.group()))} ", t)
    t = re.sub(r"[^a-z' ]+", " ", t)
    return tuple(w.strip("'") if w not in ("i'm", "we're", "you're", "i'd", "let's") else w
                 for w in t.split() if w.strip("'"))


def text_phonemes(text: str) -> tuple[str, ...]:
    """Phonemes of a whole text, words concatenated."""
    out: list[str] = []
    for w in normalize_text(text):
        out.extend(word_phonemes(w))
    return tuple(out)


def logsumexp(a: np.ndarray, axis: int | None = None) -> np.ndarray:
    """log(sum(exp(a))) along ``axis``; rows of -inf give -inf (scipy's costs ~0.2 ms a call)."""
    a = np.asarray(a, dtype=float)
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(a - m), axis=axis, keepdims=True)) + m
    return np.squeeze(out, axis=axis) if axis is not None else out.reshape(())


# -- weighted edit distance -------------------------------------------------------------------


def encode(phones: Sequence[str]) -> np.ndarray:
    """Phoneme ids for a phoneme sequence."""
    return np.fromiter((PHONEME_ID[p] for p in phones), dtype=np.int16, count=len(phones))


def edit_distance(
    a: Sequence[str],
    b: Sequence[str],
    insert_costs: Sequence[float] | None = None,
) -> float:
    """Weighted edit distance from said phonemes ``a`` to heard phonemes ``b`` (reference code).

    Substitutions cost :func:`substitution_cost`, deleting ``a[i]`` costs :func:`indel_cost`,
    inserting ``b[j]`` costs ``insert_costs[j]`` (default :func:`indel_cost`). With default
    costs the distance is a metric-like, symmetric, non-negative and zero on equal inputs.
    """
    ins = [indel_cost(p) for p in b] if insert_costs is None else list(insert_costs)
    prev = [0.0]
    for j in range(len(b)):
        prev.append(prev[-1] + ins[j])
    for i in range(len(a)):
        cur = [prev[0] + indel_cost(a[i])]
        for j in range(len(b)):
            cur.append(min(prev[j + 1] + indel_cost(a[i]), prev[j] + substitution_cost(a[i], b[j]),
                           cur[j] + ins[j]))
        prev = cur
    return prev[-1]


def batch_edit_distance(
    said: np.ndarray,
    said_del: np.ndarray,
    heard: np.ndarray,
    heard_ins: np.ndarray,
    heard_sub: np.ndarray | None = None,
) -> np.ndarray:
    """Weighted edit distances between every said and every heard sequence, vectorised.

    Args:
        said: (S, La) phoneme ids, right-padded with ``PAD``.
        said_del: (S, La) deletion costs (0 on padding).
        heard: (H, Lb) phoneme ids, right-padded with ``PAD``.
        heard_ins: (H, Lb) insertion costs (0 on padding).
        heard_sub: (H, Lb) extra cost of substituting onto each heard phoneme (default 0).

    Returns:
        (S, H) float array of distances.

    The DP runs row by row over the said sequence; within a row the insertion chain
    D[j] = min_k (T[k] + C[j] - C[k]) (C the cumulative insertion cost) is a running minimum,
    so each row is a handful of whole-array numpy operations.
    """
    n_s, la = said.shape
    n_h, lb = heard.shape
    cum = np.zeros((n_h, lb + 1), dtype=np.float32)
    np.cumsum(heard_ins, axis=1, out=cum[:, 1:])
    d = np.broadcast_to(cum, (n_s, n_h, lb + 1)).copy()
    t = np.empty_like(d)
    heard_idx = heard.astype(np.intp)
    extra = None if heard_sub is None else heard_sub[None, :, :]
    for i in range(la):
        dl = said_del[:, i].astype(np.float32)[:, None, None]
        sub = SUB_COST[said[:, i].astype(np.intp)[:, None, None], heard_idx[None, :, :]]
        if extra is not None:
            sub = sub + extra
        np.add(d, dl, out=t)
        np.minimum(t[:, :, 1:], d[:, :, :-1] + sub, out=t[:, :, 1:])
        t -= cum
        np.minimum.accumulate(t, axis=2, out=d)
        d += cum
    return d[:, :, lb]


def _pad(seqs: Sequence[np.ndarray], costs: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    width = max((len(s) for s in seqs), default=0)
    ids = np.full((len(seqs), max(width, 1)), PAD, dtype=np.int16)
    cst = np.zeros((len(seqs), max(width, 1)), dtype=np.float32)
    for k, (s, c) in enumerate(zip(seqs, costs, strict=True)):
        ids[k, : len(s)] = s
        cst[k, : len(c)] = c
    return ids, cst


@dataclass(frozen=True)
class PhonemeTrie:
    """Said sequences stored reversed in a trie, so shared endings are aligned once.

    "three forks", "two forks" and "forks" end alike; aligning reversed sequences lets every
    trie node's DP row serve all the sequences below it (about 5x fewer rows than padding on
    the default lexicon).
    """

    levels: tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]  # (parent, phoneme id, del cost)
    terminal_level: np.ndarray  # (n_seq,) depth of each sequence's node
    terminal_node: np.ndarray  # (n_seq,) its index within the level

    @classmethod
    def build(cls, seqs: Sequence[tuple[np.ndarray, np.ndarray]]) -> PhonemeTrie:
        """Build from (phoneme ids, deletion costs) pairs."""
        nodes: list[dict[tuple[int, int, float], int]] = []
        tl = np.zeros(len(seqs), dtype=np.intp)
        tn = np.zeros(len(seqs), dtype=np.intp)
        for k, (ids, costs) in enumerate(seqs):
            node = 0
            for depth, (p, c) in enumerate(zip(ids[::-1].tolist(), costs[::-1].tolist(), strict=True)):
                if depth == len(nodes):
                    nodes.append({})
                level = nodes[depth]
                key = (node, p, c)
                node = level.setdefault(key, len(level))
            tl[k], tn[k] = len(ids), node
        levels = []
        for level in nodes:
            keys = list(level)  # insertion order == node index
            levels.append((np.array([k[0] for k in keys], dtype=np.intp),
                           np.array([k[1] for k in keys], dtype=np.intp),
                           np.array([k[2] for k in keys], dtype=np.float32)))
        return cls(tuple(levels), tl, tn)


def trie_edit_distance(
    trie: PhonemeTrie, heard: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> np.ndarray:
    """Distances from every sequence in ``trie`` to every heard (ids, ins, sub) triple: (S, H)."""
    rev = [(h[0][::-1], h[1][::-1], h[2][::-1]) for h in heard]
    h_ids, h_ins = _pad([r[0] for r in rev], [r[1] for r in rev])
    _, h_sub = _pad([r[0] for r in rev], [r[2] for r in rev])
    n_h, lb = h_ids.shape
    cum = np.zeros((n_h, lb + 1), dtype=np.float32)
    np.cumsum(h_ins, axis=1, out=cum[:, 1:])
    heard_idx = h_ids.astype(np.intp)[None, :, :]
    extra = h_sub[None, :, :]
    finals = [cum[None, :, lb]]
    d = cum[None, :, :]
    for parent, phone, cost in trie.levels:
        prev = d[parent]
        t = prev + cost[:, None, None]
        np.minimum(t[:, :, 1:], prev[:, :, :-1] + SUB_COST[phone[:, None, None], heard_idx] + extra,
                   out=t[:, :, 1:])
        t -= cum
        np.minimum.accumulate(t, axis=2, out=t)
        t += cum
        d = t
        finals.append(t[:, :, lb])
    res = np.empty((len(trie.terminal_level), n_h), dtype=np.float32)
    for depth, fin in enumerate(finals):
        sel = np.nonzero(trie.terminal_level == depth)[0]
        if len(sel):
            res[sel] = fin[trie.terminal_node[sel]]
    return res


# -- the likelihood ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Plan:
    content_ids: np.ndarray  # (n_contents_used,) ids into the instance's content registry
    index: np.ndarray  # (n_commands, K) positions into content_ids
    log_prior: np.ndarray  # (n_commands, K), -inf on padding
    trie: PhonemeTrie  # the used contents' phonemes, in content_ids order
    vocab: int = 0  # which MeaningVocabulary rates the heard words (lexicon + these contents)


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
        # Words that sound like no object name, synonym, category word or count are background:
        # they cost about the same under every command (background.py, docs/likelihoods.md).
        self.background = bool(background)
        r_near, r_far = relevance_range
        if not (np.isfinite(r_near) and np.isfinite(r_far) and 0 <= r_near < r_far):
            raise ObservationError(f"relevance_range must be (near, far) with 0 <= near < far, got {relevance_range!r}")
        self.relevance_range = (float(r_near), float(r_far))
        self._lexicon_words = frozenset(lexicon_words(self.lexicon))
        # one MeaningVocabulary per set of meaning words: the lexicon's plus the content words
        # of the commands scored in the call (a class missing from the lexicon counts too)
        self._vocab_id: dict[frozenset[str], int] = {}
        self._vocabs: list[MeaningVocabulary] = []
        self._cache_size = cache_size
        self._contents: list[str] = []
        self._content_id: dict[str, int] = {}
        self._said: list[tuple[np.ndarray, np.ndarray]] = []
        self._dist: OrderedDict[tuple[int, str], np.ndarray] = OrderedDict()
        self._heard_cache: dict[tuple[int, str], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._plans: OrderedDict[tuple[RobotCommand, ...], _Plan] = OrderedDict()

    # -- encoding ------------------------------------------------------------------------------

    def _content(self, text: str) -> int:
        cid = self._content_id.get(text)
        if cid is None:
            phones: list[str] = []
            costs: list[float] = []
            for w in normalize_text(text):
                wp = word_phonemes(w)
                phones.extend(wp)
                costs.extend(indel_cost(p) for p in wp)
                if wp and wp[-1] in _STOPS:
                    # Word-final stops are often unreleased and lost ("milk" heard "mail").
                    costs[-1] *= FINAL_STOP_DISCOUNT
            self._said.append((encode(phones), np.array(costs, dtype=np.float32)))
            cid = len(self._contents)
            self._contents.append(text)
            self._content_id[text] = cid
        return cid

    def vocabulary(self, commands: Sequence[RobotCommand]) -> MeaningVocabulary:
        """The meaning words that rate heard words when scoring ``commands``."""
        return self._vocabs[self._plan(tuple(commands)).vocab]

    def _vocab_for(self, content_ids: Iterable[int]) -> int:
        words = self._lexicon_words | {w for i in content_ids for w in normalize_text(self._contents[i])}
        key = frozenset(words)
        vid = self._vocab_id.get(key)
        if vid is None:
            vid = self._vocab_id[key] = len(self._vocabs)
            self._vocabs.append(MeaningVocabulary(key, *self.relevance_range))
        return vid

    def _heard(self, text: str, vocab: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Phoneme ids, insertion costs and substitution penalties of a hypothesis (cached)."""
        key = (vocab, text)
        hit = self._heard_cache.get(key)
        if hit is None:
            hit = self._heard_cache[key] = self._encode_heard(text, vocab)
            if len(self._heard_cache) > self._cache_size:
                self._heard_cache.pop(next(iter(self._heard_cache)))
        return hit

    def _encode_heard(self, text: str, vocab: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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

    def _relevances(self, words: Sequence[str], vocab: int = 0) -> list[float]:
        """g per heard word: 0 for filler words, else how much it sounds like a meaning word,
        alone or run together with a non-filler neighbour when neither is one already ("see
        real" for "cereal", but not "egg as" for "eggs"); 1 without the background model."""
        if not self.background:
            return [0.0 if w in FILLER_WORDS else 1.0 for w in words]
        voc = self._vocabs[vocab]
        g = [0.0 if w in FILLER_WORDS else voc.relevance(w) for w in words]
        for i in range(len(words) - 1):
            a, b = words[i], words[i + 1]
            if a not in FILLER_WORDS and b not in FILLER_WORDS and max(g[i], g[i + 1]) < 1.0:
                pg = voc.pair_relevance(a, b)
                g[i], g[i + 1] = max(g[i], pg), max(g[i + 1], pg)
        return g

    def _plan(self, commands: tuple[RobotCommand, ...]) -> _Plan:
        plan = self._plans.get(commands)
        if plan is not None:
            self._plans.move_to_end(commands)
            return plan
        per_cmd = [content_prior(c, self.lexicon) for c in commands]
        used: dict[int, int] = {}
        k = max((len(p) for p in per_cmd), default=1)
        index = np.zeros((len(commands), k), dtype=np.intp)
        prior = np.full((len(commands), k), -np.inf)
        for r, pairs in enumerate(per_cmd):
            for c, (text, lp) in enumerate(pairs):
                cid = self._content(text)
                index[r, c] = used.setdefault(cid, len(used))
                prior[r, c] = lp
        ids = np.fromiter(used, dtype=np.intp, count=len(used))
        plan = _Plan(ids, index, prior, PhonemeTrie.build([self._said[i] for i in ids]), self._vocab_for(ids))
        self._plans[commands] = plan
        if len(self._plans) > 64:
            self._plans.popitem(last=False)
        return plan

    # -- distances -----------------------------------------------------------------------------

    def distances(self, texts: Sequence[str], plan: _Plan) -> np.ndarray:
        """D(h, u) for each hypothesis text and each content of ``plan``: (n_contents, n_texts).

        Rows are cached per hypothesis text (LRU), so re-scoring an instruction is a lookup.
        """
        content_ids = plan.content_ids
        out = np.empty((len(content_ids), len(texts)), dtype=np.float32)
        n_reg = len(self._contents)
        todo: list[int] = []
        vecs: list[np.ndarray] = []
        for j, t in enumerate(texts):
            key = (plan.vocab, t)
            vec = self._dist.get(key)
            if vec is None or len(vec) < n_reg:
                grown = np.full(n_reg, np.nan, dtype=np.float32)
                if vec is not None:
                    grown[: len(vec)] = vec
                vec = grown
                self._dist[key] = vec
            self._dist.move_to_end(key)
            vecs.append(vec)
            col = vec[content_ids]
            if np.isnan(col).any():
                todo.append(j)
            else:
                out[:, j] = col
        if todo:
            heard = [self._heard(texts[j], plan.vocab) for j in todo]
            nonempty = [k for k, h in enumerate(heard) if len(h[0])]
            block = np.zeros((len(content_ids), len(todo)), dtype=np.float32)
            if nonempty:
                block[:, nonempty] = trie_edit_distance(plan.trie, [heard[k] for k in nonempty])
            for k, j in enumerate(todo):
                vecs[j][content_ids] = block[:, k]
                out[:, j] = block[:, k]
        while len(self._dist) > self._cache_size:
            self._dist.popitem(last=False)
        return out

    # -- the likelihood ------------------------------------------------------------------------

    def nbest_weights(self, instruction: Instruction) -> tuple[list[str], np.ndarray]:
        """Distinct hypothesis texts and their log weights log w_n (duplicates merged)."""
        scores = np.array([h.score for h in instruction.nbest], dtype=float) / self.asr_temperature
        logw = scores - logsumexp(scores)
        merged: dict[str, float] = {}
        for h, lw in zip(instruction.nbest, logw, strict=True):
            key = " ".join(_normalize(h.text))
            merged[key] = float(np.logaddexp(merged[key], lw)) if key in merged else float(lw)
        return list(merged), np.array(list(merged.values()))

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> np.ndarray:
        """log P(phi | pi_r) for each command; shape (len(commands),)."""
        if not instruction.nbest:
            raise ObservationError(
                "the phonetic likelihood needs a transcript or an N-best list; transcribe the "
                "audio first or use the 'acoustic' likelihood"
            )
        commands = tuple(commands)
        if not commands:
            return np.zeros(0)
        plan = self._plan(commands)
        texts, logw = self.nbest_weights(instruction)
        d = self.distances(texts, plan)  # (n_contents, n_hyps)
        ch = self._channel(d, plan)
        ch[:, [len(self._heard(t, plan.vocab)[0]) == 0 for t in texts]] = 0.0  # nothing heard: uninformative
        per_content = logsumexp(logw[None, :] + ch, axis=1)
        return logsumexp(plan.log_prior + per_content[plan.index], axis=1)

    def _lost_costs(self, plan: _Plan) -> np.ndarray:
        """D(nothing, u): the cost of deleting each content of the plan (cached per plan)."""
        lost = getattr(plan, "_lost", None)
        if lost is None:
            lost = np.array([float(self._said[i][1].sum()) for i in plan.content_ids])
            object.__setattr__(plan, "_lost", lost)
        return lost

    def _channel(self, d: np.ndarray, plan: _Plan) -> np.ndarray:
        """-lam (D(h, u) - alpha D(nothing, u)) per content and hypothesis (alpha = lost_word_weight)."""
        lp = -self.lam * d.astype(float)
        if self.lost_word_weight > 0:
            lp += (self.lam * self.lost_word_weight) * self._lost_costs(plan)[:, None]
        return lp

    def explain(self, instruction: Instruction, command: RobotCommand) -> list[tuple[str, float]]:
        """(content words, log prior + log channel) for a command's phrasings, best first."""
        plan = self._plan((command,))
        texts, logw = self.nbest_weights(instruction)
        d = self.distances(texts, plan)
        per_content = logsumexp(logw[None, :] + self._channel(d, plan), axis=1)
        rows = [(self._contents[plan.content_ids[i]], float(lp + per_content[i]))
                for i, lp in zip(plan.index[0], plan.log_prior[0], strict=True) if np.isfinite(lp)]
        return sorted(rows, key=lambda r: -r[1])
