"""CMU pocketsphinx 5 (PyPI; ships the US English acoustic model, a generic trigram LM, CMUdict).

Two language models:

* generic (default): the shipped 3-gram LM and the full dictionary.
* vocabulary-biased: a small 3-gram LM built from phrasings of the scene's requests
  (``vocabulary=["pass me the cereal", ...]``), with the dictionary trimmed to their words.
  Loading takes ~0.02 s instead of ~0.3-7 s and decoding is ~10x faster, and in-domain WER
  falls sharply; the price is that words outside the phrasings cannot be recognised at all
  (they come out as the nearest in-vocabulary words). See docs/speech.md for measurements.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, cast

import numpy as np

from siftom.concurrency import guarded
from siftom.errors import SiftomError
from siftom.observation import Hypothesis
from siftom.speech.asr.base import Transcript, Word, normalise_text
from siftom.speech.audio import FRAME_RATE, SAMPLE_RATE, as_audio, to_pcm16

# keeps some of the background words given the phrasings' words (PocketsphinxEngine)
BackgroundFilter = Callable[[Sequence[tuple[str, float]], set[str]], Iterable[tuple[str, float]]]
# pocketsphinx keeps path scores in log-base-1.0001 units shifted right by 10 bits (SENSCR_SHIFT)
SENSCR_SHIFT = 10
_FILLERS = {"<s>", "</s>", "<sil>", "[noise]", "<unk>"}
# Open vocabulary (opt-in, engine name "pocketsphinx-open"): the scene's phrasings mixed with the
# most frequent words of the generic English LM, so words outside the phrasings are recognised
# as themselves, not forced onto the nearest object name (docs/speech.md, "Open vocabulary").
OPEN_BACKGROUND_WORDS = 2000
OPEN_BACKGROUND_WEIGHT = 0.1
# The phrasing LMs (not the open ones, not measured) decode in two passes (the lexicon-tree search, then the lattice's N-best) without
# pocketsphinx's flat-lexicon rescoring pass: with a vocabulary of a few hundred words the flat pass
# costs ~40 % of the decode and gains nothing measurable (docs/speech.md, "Decoder passes"); the
# search is then reset before each utterance, so one utterance decodes the same after any other.
DecoderValue = bool | int | float | str  # a pocketsphinx Decoder setting's value
FAST_PASSES: dict[str, DecoderValue] = {"fwdflat": False}
# Default request templates used when a vocabulary is given as bare object words.
REQUEST_TEMPLATES = (
    "{x}",
    "the {x}",
    "pass me the {x}",
    "can you pass me the {x}",
    "could you pass me the {x}",
    "bring me the {x}",
    "can you bring me the {x}",
    "hand me the {x}",
    "get me the {x}",
    "i need the {x}",
    "please get the {x}",
)


def _ps() -> ModuleType:
    """The pocketsphinx module (imported on first use)."""
    import pocketsphinx

    return cast(ModuleType, pocketsphinx)  # untyped: imported as Any


def model_path(sub: str) -> str:
    """Path of a file inside pocketsphinx's shipped model folder."""
    path: str = _ps().get_model_path(sub)
    return path


@functools.lru_cache(maxsize=1)
def cmudict() -> dict[str, tuple[tuple[str, ...], ...]]:
    """CMUdict as word -> pronunciations (read once per process, ~0.3 s)."""
    out: dict[str, list[tuple[str, ...]]] = {}
    with open(model_path("en-us/cmudict-en-us.dict"), encoding="utf-8") as f:
        for line in f:
            parts = line.split()
            if len(parts) < 2:
                continue
            word = parts[0].split("(")[0]
            phones = tuple(p for p in parts[1:] if not p.startswith("#"))
            out.setdefault(word, []).append(phones)
    return {w: tuple(p) for w, p in out.items()}


def cache_dir() -> Path:
    """Where generated LMs and dictionaries are kept (``$SIFTOM_CACHE_DIR``/pocketsphinx)."""
    from siftom.backends.config import cache_root

    p = cache_root() / "pocketsphinx"
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError:
        p = Path(tempfile.gettempdir()) / "siftom-pocketsphinx"
        p.mkdir(parents=True, exist_ok=True)
    return p


def write_dictionary(words: Iterable[str], path: Path) -> tuple[str, ...]:
    """Write a trimmed pronunciation dictionary; return the words CMUdict does not know."""
    cmu = cmudict()
    missing = []
    lines = []
    for w in sorted(set(words)):
        prons = cmu.get(w)
        if not prons:
            missing.append(w)
            continue
        for i, ph in enumerate(prons):
            lines.append(f"{w if i == 0 else f'{w}({i + 1})'} {' '.join(ph)}")
    _atomic_write(path, "\n".join(lines) + "\n")
    return tuple(missing)


def expand_vocabulary(items: Sequence[str]) -> tuple[str, ...]:
    """Normalise phrasings; bare single words (object names) are expanded with REQUEST_TEMPLATES."""
    phrases = [normalise_text(s) for s in items]
    phrases = [p for p in phrases if p]
    if not phrases:
        raise SiftomError("the vocabulary is empty; give phrasings like 'pass me the cereal'")
    if all(" " not in p for p in phrases):
        phrases = [t.format(x=p) for p in phrases for t in REQUEST_TEMPLATES]
    return tuple(dict.fromkeys(phrases))


def build_arpa(sentences: Sequence[str], discount: float = 0.5) -> str:
    """A 3-gram ARPA LM over the sentences with fixed-discount backoff (pocketsphinx.lm)."""
    from io import StringIO

    from pocketsphinx.lm import ArpaBoLM

    lm = ArpaBoLM(text="\n".join(sentences) + "\n", add_start=True, discount_mass=discount)
    lm.compute()
    buf = StringIO()
    lm.write(buf)
    return buf.getvalue()


def generic_unigrams(n: int) -> tuple[tuple[str, float], ...]:
    """The ``n`` most probable words of pocketsphinx's generic English LM with their log10
    unigram probabilities (dictionary words only; cached on disk, ~6 s the first time)."""
    path = cache_dir() / f"generic-unigrams-{n}.tsv"
    if not path.is_file():
        ps = _ps()
        logmath = ps.LogMath()  # keep a reference while the model is alive
        lm = ps.NGramModel(ps.Config(), logmath, model_path("en-us/en-us.lm.bin"))
        per_unit = math.log10(1.0001)  # NGramModel.prob is in log-base-1.0001 units
        rows: list[tuple[float, str]] = []
        for w in cmudict():
            if w.isalpha() and w.islower():
                lp = lm.prob([w])
                if lp > -(1 << 28):  # unknown words score about -2^29
                    rows.append((lp * per_unit, w))
        rows.sort(key=lambda r: (-r[0], r[1]))
        _atomic_write(path, "".join(f"{w}\t{lp:.4f}\n" for lp, w in rows[:n]))
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        w, lp = line.split("\t")
        out.append((w, float(lp)))
    return tuple(out)


def add_background_words(arpa: str, words: Sequence[tuple[str, float]], weight: float) -> str:
    """Mix a unigram background into an ARPA LM: P(w) -> (1 - weight) P(w) for its words, plus
    ``weight`` x the (renormalised) background distribution over new words, with backoff 1.

    After a background word the LM backs off to unigrams, so free speech around the scene's
    phrasings ("um could you get the milk from the fridge") is a loop of background words that
    re-enters the phrasings' n-grams wherever they match.
    """
    lines = arpa.splitlines()
    start = lines.index("\\1-grams:")
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("\\"))
    known: set[str] = set()
    shift = math.log10(1.0 - weight)
    uni: list[str] = []
    for line in lines[start + 1 : end]:
        parts = line.split()
        if len(parts) < 2:
            continue
        known.add(parts[1])
        lp = float(parts[0])
        parts[0] = f"{lp + shift:.4f}" if lp > -99 else parts[0]
        uni.append(" ".join(parts))
    new = [(w, lp) for w, lp in words if w not in known]
    if new:
        z = math.log10(sum(10.0 ** lp for _, lp in new))
        uni += [f"{lp - z + math.log10(weight):.4f} {w} 0.0000" for w, lp in new]
    head = [("ngram 1=" + str(len(uni))) if ln.startswith("ngram 1=") else ln for ln in lines[:start]]
    return "\n".join([*head, "\\1-grams:", *uni, "", *lines[end:]]) + "\n"


def boost_unigrams(arpa: str, words: Iterable[str], factor: float) -> str:
    """Multiply the unigram probability of ``words`` by ``factor`` (log10 + log10 factor).

    Only the back-off paths change: after a word the phrasings' n-grams do not continue (free
    speech), the LM falls back to unigrams, where a boosted object name or count competes better
    with the background words. The LM is not renormalised (pocketsphinx does not require it).
    """
    if factor == 1.0:
        return arpa
    boost = math.log10(factor)
    want = set(words)
    lines = arpa.splitlines()
    start = lines.index("\\1-grams:")
    for i in range(start + 1, len(lines)):
        if lines[i].startswith("\\"):
            break
        parts = lines[i].split()
        if len(parts) >= 2 and parts[1] in want and float(parts[0]) > -99:
            parts[0] = f"{float(parts[0]) + boost:.4f}"
            lines[i] = " ".join(parts)
    return "\n".join(lines) + "\n"


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + f".{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


class PocketsphinxEngine:
    """pocketsphinx recogniser with an optional vocabulary-biased LM.

    Args:
        vocabulary: phrasings to build a domain LM from (or bare object words, expanded with
            REQUEST_TEMPLATES); None uses the generic LM.
        max_seconds: refuse longer audio (the generic LM decodes at RTF >= 1 in noise).
        background_words: with a vocabulary, also admit this many of the generic LM's most
            frequent words (open vocabulary, e.g. OPEN_BACKGROUND_WORDS); 0 = the phrasings only.
        background_weight: unigram probability mass given to those words.
        background_filter: ``f(background_words, phrase_words) -> kept words``, e.g.
            ``siftom.likelihood.asr.distinct_words`` (drop words that sound like a meaning word).
        decoder_options: extra pocketsphinx ``Decoder`` settings (e.g. ``{"fwdflat": False}``).
        boost_words: with a vocabulary, words whose unigram probability is multiplied by ``boost``
            (e.g. the scene's object names and counts, :func:`boost_unigrams`).
        boost: that factor (1 = no boost).
    """

    def __init__(self, vocabulary: Sequence[str] | None = None, max_seconds: float = 120.0,
                 background_words: int = 0, background_weight: float = OPEN_BACKGROUND_WEIGHT,
                 background_filter: BackgroundFilter | None = None,
                 decoder_options: Mapping[str, DecoderValue] | None = None, boost_words: Iterable[str] = (),
                 boost: float = 1.0) -> None:
        """Load the decoder (fast with a vocabulary: the dictionary is trimmed)."""
        ps = _ps()
        self.max_seconds = max_seconds
        self.unknown_words: tuple[str, ...] = ()
        self._reset_search = False
        if vocabulary is None:
            self.name = "pocketsphinx"
            self.phrases: tuple[str, ...] = ()
            self._decoder = ps.Decoder(loglevel="FATAL")
        else:
            self.name = "pocketsphinx-vocab"
            phrases = expand_vocabulary(vocabulary)
            cmu = cmudict()
            self.unknown_words = tuple(sorted({w for p in phrases for w in p.split() if w not in cmu}))
            # drop unpronounceable words: the LM must not contain words the dictionary lacks
            kept = [" ".join(w for w in p.split() if w in cmu) for p in phrases]
            kept = [k for k in dict.fromkeys(kept) if k]
            if not kept:
                raise SiftomError(
                    f"none of the vocabulary words are in CMUdict ({', '.join(self.unknown_words[:10])}); "
                    "use common English spellings"
                )
            self.phrases = tuple(kept)
            if background_words < 0 or not 0 <= background_weight < 1:
                raise SiftomError(f"background_words must be >= 0 and background_weight in [0, 1), "
                                  f"got {background_words}, {background_weight}")
            open_vocab = background_words > 0 and background_weight > 0
            if open_vocab:
                self.name = "pocketsphinx-open"
            fname = getattr(background_filter, "__qualname__", "") if background_filter else ""
            tag = f"\nbackground={background_words},{background_weight},{fname}" if open_vocab else ""
            boosted = sorted(set(boost_words)) if boost != 1.0 else []
            if boost <= 0:
                raise SiftomError(f"boost must be > 0, got {boost}")
            if boosted:
                tag += f"\nboost={boost}:{' '.join(boosted)}"
            key = hashlib.sha1(("\n".join(self.phrases) + tag).encode()).hexdigest()[:16]
            d = cache_dir()
            lm_path, dict_path = d / f"{key}.arpa", d / f"{key}.dict"
            if not lm_path.is_file() or not dict_path.is_file():
                words = {w for p in self.phrases for w in p.split()}
                arpa = build_arpa(self.phrases)
                if open_vocab:
                    bg = generic_unigrams(background_words)
                    if background_filter is not None:
                        bg = tuple(background_filter(bg, words))
                    arpa = add_background_words(arpa, bg, background_weight)
                    words |= {w for w, _ in bg}
                arpa = boost_unigrams(arpa, boosted, boost)
                write_dictionary(words, dict_path)
                _atomic_write(lm_path, arpa)
            passes = {**({} if open_vocab else FAST_PASSES), **(decoder_options or {})}
            self._decoder = ps.Decoder(lm=str(lm_path), dict=str(dict_path), loglevel="FATAL", **passes)
            # without the flat pass the tree search carries score state from one utterance to the next
            # (N-best scores shift by up to a few nats): reset the whole search per utterance (9 ms)
            self._reset_search = passes.get("fwdflat") is False
        self._logmath = self._decoder.get_logmath()

    @guarded
    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Decode the whole utterance; N-best from the lattice, de-duplicated by text."""
        if nbest < 1:
            raise SiftomError(f"nbest must be >= 1, got {nbest}")
        x = as_audio(audio, max_seconds=self.max_seconds)
        dec = self._decoder
        t0 = time.perf_counter()
        # pocketsphinx carries feature (CMN) state from one utterance to the next, so the same
        # audio could give another transcript after other audio: reset it (0.1 ms)
        if self._reset_search:
            dec.reinit()
        dec.reinit_feat()
        dec.start_utt()
        dec.process_raw(to_pcm16(x), full_utt=True)
        dec.end_utt()
        hyp = dec.hyp()
        text = normalise_text(_clean(hyp.hypstr)) if hyp is not None else ""
        words: list[Word] = []
        hyps: list[Hypothesis] = []
        if hyp is not None:
            for s in dec.seg():
                w = s.word.split("(")[0].lower()
                if w in _FILLERS or w.startswith("["):
                    continue
                words.append(Word(w, s.start_frame / FRAME_RATE, (s.end_frame + 1) / FRAME_RATE))
            others: dict[str, float] = {}
            if nbest > 1:
                for i, h in enumerate(dec.nbest()):
                    if h is None or len(others) > nbest or i >= 20 * nbest:
                        break
                    t = normalise_text(_clean(h.hypstr))
                    if t and t not in others:
                        others[t] = self._ln(h.score)
            others.pop(text, None)
            rest = sorted(others.items(), key=lambda kv: -kv[1])[: nbest - 1]
            if text:
                # the decoder's best path stays first: the lattice scores can disagree slightly
                top = max([self._ln(hyp.score)] + [sc for _, sc in rest])
                hyps.append(Hypothesis(text, top))
            hyps += [Hypothesis(t, sc) for t, sc in rest]
        elapsed = time.perf_counter() - t0
        dur = len(x) / SAMPLE_RATE
        return Transcript(text, tuple(hyps), tuple(words), elapsed / dur, self.name, dur)

    def _ln(self, p: float) -> float:
        return path_score_nats(self._logmath, p)


def path_score_nats(logmath: object, p: float) -> float:
    """Turn a pocketsphinx hypothesis score (returned exponentiated) into natural-log units.

    ``logmath.log`` recovers the integer log-base-1.0001 score; pocketsphinx stores path scores
    shifted right by SENSCR_SHIFT bits, so multiply back to get nats.
    """
    if p <= 0:
        return -1e9
    return float(logmath.log_to_ln(logmath.log(p))) * (1 << SENSCR_SHIFT)  # type: ignore[attr-defined]


def _clean(text: str) -> str:
    return " ".join(w for w in text.split() if w.lower() not in _FILLERS and not w.startswith("["))


# The open decode skips pocketsphinx's second (flat-lexicon) pass: measured as accurate as with
# it on free and grammar phrasings at half the decoding time (docs/speech.md, "Open vocabulary").
OPEN_DECODER_OPTIONS: dict[str, DecoderValue] = {"fwdflat": False}


def open_vocabulary_engine(vocabulary: Sequence[str], **options: Any) -> PocketsphinxEngine:
    """The scene's phrasings mixed with the generic LM's most frequent words (docs/speech.md).
    The registered ``pocketsphinx-open`` (``siftom.likelihood.asr``) also drops the words that
    sound like an object name or count."""
    options.setdefault("background_words", OPEN_BACKGROUND_WORDS)
    options.setdefault("decoder_options", dict(OPEN_DECODER_OPTIONS))
    return PocketsphinxEngine(vocabulary=vocabulary, **options)
