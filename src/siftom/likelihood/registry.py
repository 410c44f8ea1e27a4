"""Instruction likelihoods by name, loaded lazily from ``"module:attr"`` entry points.

``get_likelihood("phonetic")`` always works offline; "llm" needs the ``llm`` extra or an
endpoint; "acoustic" needs audio. Each entry declares what it consumes, so callers can
explain a refusal before constructing anything.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from siftom.errors import ObservationError, unknown_name
from siftom.likelihood.base import Instruction, InstructionLikelihood


@dataclass(frozen=True)
class LikelihoodSpec:
    """A registered instruction likelihood."""

    name: str
    entry_point: str  # "module:attr"
    needs_text: bool
    needs_audio: bool
    summary: str

    def load(self) -> Any:
        """Import and return the class (or factory)."""
        module, _, attr = self.entry_point.partition(":")
        return getattr(importlib.import_module(module), attr)

    def check(self, instruction: Instruction) -> None:
        """Raise ObservationError when ``instruction`` lacks what this likelihood consumes."""
        if self.needs_audio and not instruction.has_audio:
            raise ObservationError(
                f"the {self.name!r} likelihood needs audio; give an audio file or use 'phonetic'"
            )
        if self.needs_text and not instruction.nbest:
            raise ObservationError(
                f"the {self.name!r} likelihood needs a transcript or N-best list; "
                "transcribe the audio first or use 'acoustic'"
            )


REGISTRY: dict[str, LikelihoodSpec] = {
    s.name: s
    for s in (
        LikelihoodSpec("phonetic", "siftom.likelihood.phonetic:PhoneticLikelihood", True, False,
                       "phoneme noisy channel over N-best transcripts (offline, default)"),
        LikelihoodSpec("llm", "siftom.likelihood.llm:LLMLikelihood", True, False,
                       "language-model token log-probs with a few-shot corrupted-instruction prompt"),
        LikelihoodSpec("acoustic", "siftom.likelihood.acoustic:AcousticLikelihood", False, True,
                       "forced alignment of candidate phrasings against the audio"),
    )
}
DEFAULT = "phonetic"


def likelihood_names() -> tuple[str, ...]:
    """Registered names, default first."""
    return (DEFAULT, *sorted(n for n in REGISTRY if n != DEFAULT))


def likelihood_spec(name: str) -> LikelihoodSpec:
    """The spec for ``name``; unknown names raise UnknownNameError with suggestions."""
    spec = REGISTRY.get(name)
    if spec is None:
        raise unknown_name("instruction likelihood", name, REGISTRY)
    return spec


def get_likelihood(name: str = DEFAULT, **kwargs: Any) -> InstructionLikelihood:
    """Construct the likelihood registered as ``name`` with ``kwargs``."""
    return likelihood_spec(name).load()(**kwargs)
