"""Score candidate sentences against audio by pocketsphinx forced alignment.

For each candidate text the decoder is forced through that word sequence (``set_align_text``)
with wide beams (``bestpath=False, beam=1e-80, pbeam=1e-80, wbeam=1e-60``: with the default
beams the forced path is often pruned away on noisy clips and no score comes back;
``siftom bench acoustic --snr 10`` exercises noisy clips) and the best path score is read back in nats. The score is
log P(audio | text) up to a per-frame normalisation that is the same for every candidate of one
utterance, so scores compare only within one utterance. About 20-35 ms per candidate on a
2-3 s clip.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from siftom.concurrency import guarded
from siftom.errors import SiftomError
from siftom.speech.asr.base import normalise_text
from siftom.speech.asr.pocketsphinx import (
    _ps,
    cache_dir,
    cmudict,
    path_score_nats,
    write_dictionary,
)
from siftom.speech.audio import SAMPLE_RATE, as_audio, to_pcm16

FAILED_SCORE = -1e6  # a candidate the aligner could not fit: far below any real score, finite
_SEED_WORDS = ("the", "a", "me", "pass", "bring", "can", "you")


@dataclass(frozen=True)
class AlignmentScores:
    """Alignment scores of candidate texts against one utterance.

    Attributes:
        texts: the candidate texts (normalised), in the order given.
        scores: natural-log alignment scores, FAILED_SCORE where alignment failed.
        seconds: wall time spent aligning.
        audio_s: duration of the audio.
    """

    texts: tuple[str, ...]
    scores: tuple[float, ...]
    seconds: float
    audio_s: float

    @property
    def best(self) -> str:
        """The best-scoring text."""
        return self.texts[int(np.argmax(self.scores))]


class ForcedAligner:
    """Reusable pocketsphinx alignment decoder; words are added to its dictionary on demand."""

    def __init__(self, max_seconds: float = 120.0) -> None:
        """Load the acoustic model with a tiny dictionary (fast); see module doc for the beams."""
        ps = _ps()
        self.max_seconds = max_seconds
        dict_path = cache_dir() / "align-seed.dict"
        if not dict_path.is_file():
            write_dictionary(_SEED_WORDS, dict_path)
        self._decoder = ps.Decoder(
            lm=None, dict=str(dict_path), bestpath=False, beam=1e-80, pbeam=1e-80, wbeam=1e-60,
            loglevel="FATAL",
        )
        self._logmath = self._decoder.get_logmath()
        self._known: set[str] = set(_SEED_WORDS)
        self.skipped_words: set[str] = set()

    def prepare(self, text: str) -> str:
        """Normalise a candidate, split unknown compounds (``cuttingboard``), add its words.

        Words that cannot be pronounced from CMUdict are dropped (listed in ``skipped_words``).
        """
        out: list[str] = []
        cmu = cmudict()
        for w in normalise_text(text.replace("_", " ")).split():
            parts = [w] if w in cmu else (split_compound(w) or [])
            if not parts:
                self.skipped_words.add(w)
                continue
            for part in parts:
                if part not in self._known:
                    for i, ph in enumerate(cmu[part]):
                        name = part if i == 0 else f"{part}({i + 1})"
                        self._decoder.add_word(name, " ".join(ph), update=True)
                    self._known.add(part)
                out.append(part)
        return " ".join(out)

    @guarded
    def score(self, audio: np.ndarray | str | Path, texts: Sequence[str]) -> AlignmentScores:
        """Align every text against the audio; return their log scores in nats."""
        if not texts:
            raise SiftomError("no candidate texts to score; give at least one phrasing")
        x = as_audio(audio, max_seconds=self.max_seconds)
        pcm = to_pcm16(x)
        t0 = time.perf_counter()
        prepared = [self.prepare(t) for t in texts]
        cache: dict[str, float] = {}
        scores = []
        for p in prepared:
            if p not in cache:
                cache[p] = self._align(pcm, p) if p else FAILED_SCORE
            scores.append(cache[p])
        return AlignmentScores(
            tuple(normalise_text(t) for t in texts), tuple(scores), time.perf_counter() - t0,
            len(x) / SAMPLE_RATE,
        )

    def _align(self, pcm: bytes, text: str) -> float:
        dec = self._decoder
        try:
            dec.set_align_text(text)
            dec.reinit_feat()  # no feature state from the previous alignment (see asr/pocketsphinx.py)
            dec.start_utt()
            dec.process_raw(pcm, full_utt=True)
            dec.end_utt()
        except RuntimeError:
            return FAILED_SCORE
        hyp = dec.hyp()
        if hyp is None:
            return FAILED_SCORE
        return path_score_nats(self._logmath, hyp.score)


def split_compound(word: str) -> list[str] | None:
    """Split a run-together word into CMUdict words (``wineglass`` -> wine glass), fewest parts."""
    return _split(word)


@functools.lru_cache(maxsize=4096)
def _split(word: str) -> list[str] | None:
    cmu = cmudict()
    n = len(word)
    best: list[list[str] | None] = [None] * (n + 1)
    best[0] = []
    for i in range(1, n + 1):
        for j in range(max(0, i - 20), i):
            prev = best[j]
            piece = word[j:i]
            if prev is not None and (len(piece) > 1 or piece == "a") and piece in cmu:
                cand = prev + [piece]
                if best[i] is None or len(cand) < len(best[i]):  # type: ignore[arg-type]
                    best[i] = cand
    return best[n]
