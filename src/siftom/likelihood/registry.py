"""Instruction likelihoods by name (one :class:`~siftom.registry.Registry`).

``get_likelihood("phonetic")`` always works offline; "llm" needs an endpoint
(``SIFTOM_LLM_BASE_URL``) or the ``llm`` extra; "acoustic" needs audio. Each entry declares
what it consumes (``needs_text``, ``needs_audio``), so callers explain a refusal before
constructing anything: :func:`check_instruction`.
"""

from __future__ import annotations

from typing import Any

from siftom.errors import ObservationError
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.registry import Entry, Registry
from siftom.speech.asr.base import ENGINES

DEFAULT = "phonetic"
LIKELIHOODS = Registry("instruction likelihood", default=DEFAULT)
LIKELIHOODS.register("phonetic", "siftom.likelihood.phonetic:PhoneticLikelihood",
                     summary="phoneme noisy channel over N-best transcripts (offline, default)",
                     attrs={"needs_text": True, "needs_audio": False})
LIKELIHOODS.register("llm", "siftom.likelihood.llm:LLMLikelihood",
                     summary="language-model token log-probs with a few-shot corrupted-instruction prompt",
                     checker="siftom.backends.config:llm_missing",
                     attrs={"needs_text": True, "needs_audio": False})
LIKELIHOODS.register("acoustic", "siftom.likelihood.acoustic:AcousticLikelihood",
                     summary="the audio: Whisper teacher-forced scores of each command (whisper extra) "
                             "or key-phrase forced alignment, times the N-best",
                     attrs={"needs_text": False, "needs_audio": True})

# an ASR engine that needs the likelihoods' meaning words, so it registers from this layer
ENGINES.register("pocketsphinx-open", "siftom.likelihood.asr:open_engine",
                 summary="the scene's phrasings mixed with frequent English words (open vocabulary)",
                 requires=("pocketsphinx",), attrs={"scene": True})


AUTO = "auto"  # the best likelihood the input and the installed extras allow: resolve_likelihood


def resolve_likelihood(name: str | None, has_audio: bool) -> tuple[str, str]:
    """(likelihood to run, why) for a request; ``None`` or ``"auto"`` picks the best available.

    With audio and the whisper extra that is ``acoustic`` (the N-best and Whisper's
    teacher-forced score of each command: the more accurate one, docs/likelihoods.md); without
    the whisper extra, or for a transcript (no sound to score), ``phonetic``. A name given
    explicitly runs as asked.
    """
    if name is not None and name != AUTO:
        LIKELIHOODS.spec(name)  # unknown names suggest close matches
        return name, "asked for"
    if not has_audio:
        return "phonetic", "no audio: a transcript is scored by its phonemes"
    from siftom.likelihood.whisper_factor import whisper_available

    if whisper_available():
        return "acoustic", "audio with the whisper extra: Whisper scores each command against the recording"
    return "phonetic", "audio without the whisper extra: install siftom[whisper] for the acoustic likelihood"


def likelihood_names() -> tuple[str, ...]:
    """Registered names, default first."""
    return LIKELIHOODS.names()


def likelihood_spec(name: str) -> Entry:
    """The entry for ``name``; unknown names raise UnknownNameError with suggestions."""
    return LIKELIHOODS.spec(name)


def check_instruction(name: str, instruction: Instruction) -> None:
    """Raise ObservationError when ``instruction`` lacks what likelihood ``name`` consumes."""
    attrs = LIKELIHOODS.spec(name).attrs
    if attrs.get("needs_audio") and not instruction.has_audio:
        raise ObservationError(f"the {name!r} likelihood needs the audio; give an audio file or use 'phonetic'")
    if attrs.get("needs_text") and not instruction.nbest:
        raise ObservationError(f"the {name!r} likelihood needs a transcript or N-best list; "
                               "transcribe the audio first or use 'acoustic'")


def get_likelihood(name: str = DEFAULT, **kwargs: Any) -> InstructionLikelihood:
    """Check, then construct the likelihood registered as ``name`` with ``kwargs``.

    An explicit ``backend`` argument configures "llm" itself, so the environment check is
    skipped then (the backend is validated when the scorer is built).
    """
    entry = LIKELIHOODS.spec(name)
    lik: InstructionLikelihood = entry.build(**kwargs) if kwargs.get("backend") is not None else entry.make(**kwargs)
    return lik
