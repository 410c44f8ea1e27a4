"""One interface for speech recognisers: ``transcribe(audio, nbest=N) -> Transcript``.

Engines are registered by name and load lazily (``get_engine('whisper')`` imports
faster-whisper only then). Scores are natural-log scores from the engine; they compare only
between the hypotheses of one utterance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from siftom.errors import ObservationError
from siftom.observation import Hypothesis, Instruction
from siftom.registry import Registry


@dataclass(frozen=True)
class Word:
    """A recognised word with its start and end in seconds."""

    text: str
    start: float
    end: float

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        return {"text": self.text, "start": round(self.start, 3), "end": round(self.end, 3)}


@dataclass(frozen=True)
class Transcript:
    """What an engine heard: the 1-best text, the N-best list (best first), word timings, cost.

    Attributes:
        text: 1-best transcript, lower case, '' when nothing was recognised.
        nbest: hypotheses best first, each with a natural-log score (higher is better).
        words: 1-best words with timings.
        rtf: real-time factor (decoding seconds / audio seconds).
        engine: the engine's registry name.
        audio_s: duration of the audio in seconds.
    """

    text: str
    nbest: tuple[Hypothesis, ...] = ()
    words: tuple[Word, ...] = ()
    rtf: float = 0.0
    engine: str = ""
    audio_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    def to_json(self) -> dict[str, Any]:
        """JSON object with keys text, nbest [{text, score}], words, rtf, engine, audio_s."""
        return {
            "text": self.text,
            "nbest": [{"text": h.text, "score": round(float(h.score), 4)} for h in self.nbest],
            "words": [w.to_json() for w in self.words],
            "rtf": round(self.rtf, 4),
            "engine": self.engine,
            "audio_s": round(self.audio_s, 3),
        }

    def to_instruction(self, audio: Path | None = None, samples: np.ndarray | None = None) -> Instruction:
        """The transcript as an Instruction for the likelihoods (keeps the audio path / samples if given)."""
        hyps = tuple(h for h in self.nbest if h.text) or (Hypothesis(self.text, 0.0),)
        words = tuple((w.text, w.start, w.end) for w in self.words)
        if not any(h.text for h in hyps) and (audio is not None or samples is not None):
            return Instruction(nbest=(), audio=audio, samples=samples)
        return Instruction(nbest=hyps, audio=audio, samples=samples, words=words,
                           scene_words=writes_scene_words(self.engine))


@runtime_checkable
class ASREngine(Protocol):
    """A speech recogniser."""

    name: str

    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Recognise 16 kHz mono samples or an audio file; return up to ``nbest`` hypotheses."""
        ...


DEFAULT_ENGINE = "pocketsphinx"
ENGINES = Registry("ASR engine", default=DEFAULT_ENGINE)
ENGINES.register("pocketsphinx", "siftom.speech.asr.pocketsphinx:PocketsphinxEngine",
                 summary="CMU pocketsphinx; generic English LM, or the scene's phrasings when given a vocabulary",
                 requires=("pocketsphinx",), attrs={"scene": False})
ENGINES.register("pocketsphinx-vocab", "siftom.speech.asr.pocketsphinx:PocketsphinxEngine",
                 summary="pocketsphinx with an LM of the scene's command phrasings (the evaluator's default)",
                 requires=("pocketsphinx",), attrs={"scene": True})
ENGINES.register("pocketsphinx-dual", "siftom.speech.asr.dual:DualEngine",
                 summary="pocketsphinx-vocab and pocketsphinx-open on the same audio, N-best lists mixed",
                 requires=("pocketsphinx",), attrs={"scene": True})
ENGINES.register("whisper", "siftom.speech.asr.whisper:WhisperEngine",
                 summary="faster-whisper tiny.en (int8, CPU)", requires=("faster_whisper",), extra="whisper",
                 attrs={"scene": False})
ENGINES.register("openai", "siftom.speech.asr.openai_server:OpenAITranscriptionEngine",
                 summary="an OpenAI-compatible transcription server (SIFTOM_ASR_BASE_URL, SIFTOM_ASR_MODEL); "
                         "N-best from samples at several temperatures", attrs={"scene": False})


def get_engine(name: str = DEFAULT_ENGINE, vocabulary: Sequence[str] | None = None, **options: Any) -> ASREngine:
    """Build a registered engine; a scene engine (``attrs["scene"]``) needs the scene's
    ``vocabulary`` (its command phrasings). Raises UnknownNameError or BackendUnavailableError."""
    entry = ENGINES.spec(name)
    if entry.attrs.get("scene") and vocabulary is None:
        raise ObservationError(f"the ASR engine {name!r} is built from the scene's command phrasings: pass "
                               "vocabulary= (siftom.likelihood.phrasing.command_vocabulary)")
    if vocabulary is not None:
        options["vocabulary"] = list(vocabulary)
    engine: ASREngine = entry.make(**options)  # the registry imports its classes by name: untyped
    return engine


def is_scene_engine(name: str) -> bool:
    """Whether the engine is built per scene (its LM from the scene's phrasings)."""
    return bool(ENGINES.spec(name).attrs.get("scene"))


def writes_scene_words(engine: str | None) -> bool:
    """Whether a transcript by ``engine`` (a registered name, as ``Transcript.engine`` says it)
    can only hold the scene's phrasings; False for an unknown or missing name."""
    try:
        return bool(engine) and is_scene_engine(str(engine))
    except Exception:  # an engine this installation does not register
        return False


def normalise_text(text: str) -> str:
    """Lower case, keep letters, digits and apostrophes, single spaces."""
    out = "".join(c if c.isalnum() or c == "'" else " " for c in text.lower())
    return " ".join(out.split())
