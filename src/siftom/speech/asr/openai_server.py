"""Recognition by an OpenAI-compatible transcription server (``POST /v1/audio/transcriptions``).

Servers that speak this API: faster-whisper servers (speaches, formerly faster-whisper-server),
whisper.cpp's ``whisper-server`` (``--inference-path /v1/audio/transcriptions``), vLLM with a
Whisper model, and hosted APIs. docs/speech.md gives the commands for two of them.

Each request sends the clip (16 kHz mono 16-bit WAV) as ``multipart/form-data`` with
``response_format=verbose_json``, so the answer has ``segments`` with their ``avg_logprob``
(and ``no_speech_prob``) and, where the server offers them, word times. A server returns one
transcript per request, so the N-best list is built from several requests at rising sampling
temperatures (``temperatures``: the first, 0, is the greedy transcript); a hypothesis's score is
its segments' mean token log-probability (``avg_logprob`` weighted by tokens where the server
lists them), distinct texts are kept once (their best score) and ordered best first. Word times
come from the greedy answer when it is the 1-best. As in the local Whisper engine, an answer
whose every segment has ``no_speech_prob`` > 0.6 and ``avg_logprob`` < -1 is silence.

Endpoint, key, timeouts, retries and the on-disk answer cache are those of the LLM client
(``siftom.backends.openai_compat``, ``LLMConfig``), read from ``SIFTOM_ASR_BASE_URL``,
``SIFTOM_ASR_MODEL`` and ``SIFTOM_ASR_API_KEY`` (the timeout, retries and cache folder from the
same ``SIFTOM_LLM_TIMEOUT``, ``SIFTOM_LLM_MAX_RETRIES`` and ``SIFTOM_CACHE_DIR``), or given as
arguments. Sampled answers are cached too, so a rerun replays them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import BackendUnavailableError, SiftomError
from siftom.observation import Hypothesis
from siftom.settings.environment import ASR_API_KEY as ENV_ASR_API_KEY
from siftom.settings.environment import ASR_BASE_URL as ENV_ASR_BASE_URL
from siftom.settings.environment import ASR_MODEL as ENV_ASR_MODEL
from siftom.settings.environment import read
from siftom.speech.asr.base import Transcript, Word, normalise_text
from siftom.speech.audio import SAMPLE_RATE, as_audio, wav_bytes

DEFAULT_TEMPERATURES = (0.0, 0.2, 0.4, 0.6, 0.8)
NO_SPEECH_PROB = 0.6
NO_SPEECH_LOGPROB = -1.0
PATH = "audio/transcriptions"


class OpenAITranscriptionEngine:
    """An ASR engine over an OpenAI-compatible ``/v1/audio/transcriptions`` endpoint (module doc).

    Args:
        base_url: the API root, e.g. ``http://127.0.0.1:8000/v1`` (default ``$SIFTOM_ASR_BASE_URL``).
        model: the model name the server serves (default ``$SIFTOM_ASR_MODEL``).
        api_key: bearer token (default ``$SIFTOM_ASR_API_KEY``; none sent when empty).
        temperatures: sampling temperature of each request, the first for the 1-best; N-best lists
            use the first ``min(nbest, len(temperatures))``.
        language: the ``language`` field (None: not sent).
        prompt: an optional ``prompt`` field (e.g. the scene's object names).
        use_cache: keep answers on disk (the LLM client's cache).
        **settings: ``timeout_s``, ``max_retries``, ``cache_dir``, ``backoff_s`` as for the LLM client.
    """

    name = "openai"

    def __init__(self, base_url: str | None = None, model: str | None = None, api_key: str | None = None,
                 temperatures: Sequence[float] = DEFAULT_TEMPERATURES, language: str | None = "en",
                 prompt: str | None = None, use_cache: bool = True, **settings: Any) -> None:
        """Check the settings; nothing is sent until the first clip."""
        from siftom.backends.openai_compat import OpenAIClient

        base_url = base_url or read(ENV_ASR_BASE_URL)
        model = model or read(ENV_ASR_MODEL)
        if not base_url:
            raise BackendUnavailableError(
                f"the 'openai' ASR engine needs a transcription server: set {ENV_ASR_BASE_URL} (or base_url=) "
                "to its API root, e.g. http://127.0.0.1:8000/v1 (docs/speech.md shows how to start one)")
        if not model:
            raise BackendUnavailableError(
                f"the 'openai' ASR engine needs a model name: set {ENV_ASR_MODEL} (or model=) to a model the "
                "server serves, e.g. Systran/faster-whisper-small.en")
        temps = tuple(float(t) for t in temperatures)
        if not temps or any(not np.isfinite(t) or not 0 <= t <= 1 for t in temps):
            raise SiftomError(f"temperatures must be one or more numbers in [0, 1], got {temperatures!r}")
        backoff = settings.pop("backoff_s", 0.5)
        self.client = OpenAIClient(base_url=base_url, model=model,
                                   api_key=api_key or read(ENV_ASR_API_KEY),
                                   use_cache=use_cache, backoff_s=backoff, **settings)
        self.temperatures, self.language, self.prompt = temps, language, prompt

    def _ask(self, wav: bytes, temperature: float) -> dict[str, Any]:
        fields = [("model", self.client.model), ("response_format", "verbose_json"),
                  ("temperature", f"{temperature:g}"), ("timestamp_granularities[]", "segment"),
                  ("timestamp_granularities[]", "word")]
        if self.language:
            fields.append(("language", self.language))
        if self.prompt:
            fields.append(("prompt", self.prompt))
        data = self.client.post_form(PATH, fields, [("file", "clip.wav", wav, "audio/wav")])
        if not isinstance(data.get("text"), str):
            from siftom.backends.openai_compat import EndpointCapabilityError

            raise EndpointCapabilityError(
                f"{self.client.base_url}/{PATH} answered without a 'text' field; the engine needs an "
                "OpenAI-compatible transcription server (response_format=verbose_json)")
        return data

    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Send the clip once per temperature (module doc) and return the N-best transcript."""
        if nbest < 1:
            raise SiftomError(f"nbest must be >= 1, got {nbest}")
        x = as_audio(audio)
        dur = len(x) / SAMPLE_RATE
        t0 = time.perf_counter()
        wav = wav_bytes(x)
        scored: dict[str, float] = {}
        words: tuple[Word, ...] = ()
        first_text = ""
        for k, temp in enumerate(self.temperatures[: max(1, min(nbest, len(self.temperatures)))]):
            data = self._ask(wav, temp)
            text, score = read_answer(data)
            if k == 0:
                first_text, words = text, read_words(data)
            if text and (text not in scored or score > scored[text]):
                scored[text] = score
        hyps = tuple(sorted((Hypothesis(t, s) for t, s in scored.items()), key=lambda h: -h.score))[:nbest]
        best = hyps[0].text if hyps else ""
        return Transcript(text=best, nbest=hyps, words=words if best == first_text else (),
                          rtf=(time.perf_counter() - t0) / max(dur, 1e-6), engine=self.name, audio_s=dur)


def read_answer(data: dict[str, Any]) -> tuple[str, float]:
    """(normalised text, mean token log-prob) of a verbose_json answer; ('', 0) for silence."""
    segs = [s for s in data.get("segments") or [] if isinstance(s, dict)]
    text = normalise_text(str(data.get("text", "")))
    if not segs:
        return text, 0.0
    lps = [float(s.get("avg_logprob", 0.0)) for s in segs]
    if all(float(s.get("no_speech_prob", 0.0)) > NO_SPEECH_PROB for s in segs) and max(lps) < NO_SPEECH_LOGPROB:
        return "", 0.0
    weights = [max(1, len(s.get("tokens") or ())) for s in segs]
    return text, float(np.average(lps, weights=weights))


def read_words(data: dict[str, Any]) -> tuple[Word, ...]:
    """Word times of a verbose_json answer (its ``words`` list, or its segments' ``words``)."""
    raw = data.get("words") or [w for s in data.get("segments") or [] for w in (s.get("words") or [])]
    out: list[Word] = []
    for w in raw:
        t = normalise_text(str(w.get("word", "")))
        if t:
            out.extend(Word(part, float(w.get("start", 0.0)), float(w.get("end", 0.0))) for part in t.split())
    return tuple(out)
