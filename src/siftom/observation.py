"""What the robot observes of an instruction: an ASR N-best list and/or the audio.

These types sit below both the speech stage (which produces them) and the likelihoods (which
consume them), as whisper's ``DecodingOptions``/``DecodingResult`` sit below its stages.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from siftom.errors import ObservationError


@dataclass(frozen=True)
class Hypothesis:
    """One ASR hypothesis with its log score (natural log, higher is better)."""

    text: str
    score: float = 0.0


@dataclass(frozen=True)
class Instruction:
    """What was heard: a transcript, an ASR N-best list, and/or the audio itself.

    ``nbest`` is ordered best first. A bare transcript is an N-best list of length one.
    """

    nbest: tuple[Hypothesis, ...] = ()
    audio: Path | None = None
    reference: str | None = field(default=None, compare=False)
    # the audio already decoded (16 kHz mono float32), so likelihoods need not read ``audio`` again
    samples: np.ndarray | None = field(default=None, compare=False, repr=False)
    # 1-best word timings from the recogniser: (text, start s, end s) each
    words: tuple[tuple[str, float, float], ...] = field(default=(), compare=False, repr=False)
    # speech-to-background ratio estimated by voice-activity detection (dB), when known
    snr_db: float | None = field(default=None, compare=False, repr=False)
    # which target of the utterance the words are scored for (siftom.language): the k-th object
    # asked for in "the cereal and the sugar"; None: every target
    focus: int | None = field(default=None, compare=False)
    # the N-best came from a recogniser that can only write the scene's phrasings (a scene engine
    # such as pocketsphinx-vocab): an object's exact name in it is weak evidence, since it writes
    # some scene name whatever was said (the slot channel is off for it)
    scene_words: bool = field(default=False, compare=False)

    def __post_init__(self) -> None:
        if not self.nbest and self.audio is None and self.samples is None:
            raise ObservationError(
                "an instruction needs a transcript, an N-best list or an audio file; "
                "pass e.g. Instruction.from_text('pass me the cereal')"
            )
        for h in self.nbest:
            if not isinstance(h.text, str):
                raise ObservationError(f"N-best text must be a string, got {type(h.text).__name__}")
            if not np.isfinite(h.score):
                raise ObservationError(f"N-best score for {h.text!r} is not finite: {h.score}")

    @classmethod
    def from_text(cls, text: str) -> Instruction:
        """Wrap a single transcript."""
        if not isinstance(text, str) or not text.strip():
            raise ObservationError("the transcript is empty; give the words that were heard")
        return cls(nbest=(Hypothesis(text.strip(), 0.0),))

    @classmethod
    def from_nbest(cls, items: Sequence[tuple[str, float] | Hypothesis]) -> Instruction:
        """Wrap an N-best list of (text, log score) pairs, best first."""
        hyps = tuple(h if isinstance(h, Hypothesis) else Hypothesis(str(h[0]), float(h[1])) for h in items)
        if not hyps:
            raise ObservationError("the N-best list is empty; give at least one hypothesis")
        return cls(nbest=hyps)

    @property
    def has_audio(self) -> bool:
        """Whether the recording itself is available (a path or decoded samples)."""
        return self.audio is not None or self.samples is not None

    @property
    def text(self) -> str:
        """The 1-best transcript ('' when only audio is known)."""
        return self.nbest[0].text if self.nbest else ""
