"""Words to ARPAbet phonemes, and how far apart two phonemes sound.

Pronunciations come from the CMUdict that pocketsphinx ships (the recogniser's own
vocabulary, so every word it outputs is there). Unknown words (typed transcripts, new class
names) go through espeak-ng's IPA output mapped onto ARPAbet, and, when espeak-ng is absent,
through a letter-to-sound table. All lookups are cached per process. Substitution and
insertion/deletion costs come from articulatory features (place, manner, voicing; vowel
height and backness).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

import numpy as np

from siftom.likelihood.numbers import number_word

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


