"""Acoustic instruction likelihood: score the audio itself against each command's phrasings.

For robot command pi_r with phrasings u (text) and log prior log P(u | pi_r), and audio a,

    log P(a | pi_r) = logsumexp_u [ s(a, u) / T + log P(u | pi_r) ]

where s(a, u) is the pocketsphinx forced-alignment score of u against a, in nats
(siftom.speech.acoustic), and T is a temperature in nats that turns raw alignment scores,
which are over-confident, into a likelihood (paper, Methods, Instruction Likelihood; the
paper's P(phi | pi_r) with phi the audio instead of a transcript). T must grow with noise:
measured best T is about 12 at 20 dB SNR and about 30 at 0 dB (FINDINGS.md); see
``temperature_for_snr``. Scores compare only across the commands of one call.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from siftom.errors import ObservationError, SiftomError
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

Phrasings = Callable[[RobotCommand], Sequence[tuple[str, float]]]
DEFAULT_TEMPERATURE = 20.0


def temperature_for_snr(snr_db: float | None) -> float:
    """A temperature in nats for a known SNR: 12 at >= 20 dB (or clean) rising to 30 at <= 0 dB."""
    if snr_db is None or not np.isfinite(snr_db):
        return 12.0
    s = float(np.clip(snr_db, 0.0, 20.0))
    return 30.0 - 0.9 * s


def top_phrasings(command: RobotCommand, k: int = 1) -> list[tuple[str, float]]:
    """The ``k`` most likely phrasings of a command (default phrasing model and lexicon).

    Forced alignment costs ~20 ms per sentence, so by default each command is represented by its
    single most likely sentence; the carrier words are then shared by all candidates and the
    alignment scores differ where the object words do.
    """
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import phrasings

    items = sorted(phrasings(command, default_lexicon()), key=lambda t: -t[1])[:k]
    top = float(logsumexp([lp for _, lp in items]))
    return [(t, lp - top) for t, lp in items]


def closest_phrasing(command: RobotCommand, heard: str) -> tuple[str, float]:
    """The phrasing of ``command`` with the smallest word edit distance to ``heard``."""
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import phrasings
    from siftom.speech.metrics import edit_distance

    words = heard.lower().split()
    best = min(phrasings(command, default_lexicon()),
               key=lambda t: (edit_distance(t[0].lower().split(), words), -t[1]))
    return best[0], 0.0


class AcousticLikelihood:
    """log P(audio | robot command) by forced alignment of the command's phrasings.

    Args:
        phrasings: maps a command to (text, log prior) pairs; default :func:`top_phrasings`.
        temperature: T in nats (see module doc); must be > 0.
        aligner: a ForcedAligner to share between likelihoods (one is created lazily otherwise).
    """

    def __init__(
        self,
        phrasings: Phrasings | None = None,
        temperature: float = DEFAULT_TEMPERATURE,
        aligner: object | None = None,
        name: str = "acoustic",
    ) -> None:
        """Validate the temperature; the aligner loads on first use."""
        if not np.isfinite(temperature) or temperature <= 0:
            raise SiftomError(f"temperature must be a positive number of nats, got {temperature}")
        self.phrasings = phrasings or top_phrasings
        self.temperature = float(temperature)
        self.name = name
        self._aligner = aligner
        self.last_seconds = 0.0
        self.last_candidates = 0

    @property
    def aligner(self):  # noqa: ANN201 - ForcedAligner, imported lazily
        """The shared ForcedAligner."""
        if self._aligner is None:
            from siftom.speech.acoustic import ForcedAligner

            self._aligner = ForcedAligner()
        return self._aligner

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> np.ndarray:
        """Return log P(audio | command) for each command, shape (len(commands),)."""
        if instruction.audio is None:
            raise ObservationError(
                "the acoustic likelihood needs the audio: send the recording (multipart field audio, --audio FILE "
                "or Instruction(audio=PATH)), or use a transcript-based likelihood such as phonetic"
            )
        heard = instruction.text if instruction.nbest else None
        return self.log_prob_audio(instruction.audio, commands, heard=heard)

    def log_prob_audio(self, audio: np.ndarray | str | Path, commands: Sequence[RobotCommand],
                       heard: str | None = None) -> np.ndarray:
        """Same as ``log_prob`` for raw 16 kHz samples or a path.

        With ``heard`` (an ASR 1-best), each command is scored with its phrasing closest in
        words to what was heard: the carrier ("can you pass me the ...") then matches the audio
        and the scores differ where the object words do.
        """
        if not commands:
            return np.zeros(0)
        per_cmd: list[list[tuple[str, float]]] = []
        texts: dict[str, None] = {}
        for c in commands:
            items = [(str(t), float(lp)) for t, lp in (self.phrasings(c) if heard is None else
                                                       [closest_phrasing(c, heard)])]
            if not items:
                raise SiftomError(f"no phrasings for command {c}; the phrasing function returned none")
            per_cmd.append(items)
            texts.update(dict.fromkeys(t for t, _ in items))
        unique = list(texts)
        result = self.aligner.score(audio, unique)
        score = dict(zip(unique, result.scores, strict=True))
        self.last_seconds = result.seconds
        self.last_candidates = len(unique)
        out = np.empty(len(commands))
        for i, items in enumerate(per_cmd):
            out[i] = logsumexp([score[t] / self.temperature + lp for t, lp in items])
        return out
