"""Alignment scores before and after the temperature: what the acoustic likelihood
(:mod:`siftom.likelihood.acoustic`) aligned, and how it turns that into log-likelihoods."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.errors import SiftomError
from siftom.logspace import logsumexp

if TYPE_CHECKING:
    from siftom.speech.acoustic import ForcedAligner
    from siftom.world.commands import RobotCommand

FAILED = -1e5  # alignment scores at or below this are failures (siftom.speech.acoustic.FAILED_SCORE)


def temperature_for_snr(snr_db: float | None) -> float:
    """A temperature in nats for a known SNR: 12 at >= 20 dB (or clean) rising to 30 at <= 0 dB."""
    if snr_db is None or not np.isfinite(snr_db):
        return 12.0
    s = float(np.clip(snr_db, 0.0, 20.0))
    return 30.0 - 0.9 * s


@dataclass(frozen=True)
class RawScores:
    """Alignment scores before the temperature: per kept command, (score in nats, log prior) items."""

    keep: np.ndarray
    items: tuple[list[tuple[float, float]], ...]
    mode: str
    phonetic: np.ndarray | None = None  # the N-best phonetic log-likelihood of every command, when known
    gap: float | None = None  # (free phone loop - best alignment) / frames over the aligned audio, when measured
    whisper: np.ndarray | None = None  # the Whisper factor w of each kept command (nats), when used
    evidence: Mapping[str, Any] = field(default_factory=dict)  # how this call scored (Scores.evidence)
    whisper_keep: np.ndarray | None = None  # the commands ``whisper`` scores, when not all of ``keep``

    def temperature(self, T: float, scale: float) -> float:
        """T grown by exp(scale * gap) when the best key phrase fits the frames worse than free phones."""
        if self.gap is None or not np.isfinite(self.gap) or scale == 0:
            return T
        return T * float(np.exp(scale * max(self.gap, 0.0)))


def combine_scores(raw: RawScores, n: int, T0: float, gap_scale: float, with_phonetic: bool,
                   whisper_temperature: float, pool: str = "product") -> np.ndarray:
    """Raw alignment scores as log-likelihoods at temperature ``T0`` (grown by the gap, ``gap_scale``);
    ``with_phonetic``: with the N-best phonetic likelihood; and the Whisper factor / T_w, the
    N-best and Whisper pooled by ``pool`` (``likelihood.pooling``: "product" or "mixture")."""
    from siftom.likelihood.pooling import pool_experts

    if n == 0:
        return np.zeros(0)
    phon = raw.phonetic if with_phonetic else None
    if not raw.items:  # no alignment (the Whisper factor replaces it): the N-best and w only
        return np.zeros(n) + pool_experts(phon, whisper_term(raw, n, whisper_temperature), pool)
    T = raw.temperature(T0, gap_scale)
    # a failed alignment (the decoder found no path) says nothing about the command: it gets
    # the worst score that did come back, not FAILED_SCORE / T (thousands of nats against it)
    ok = [sc for items in raw.items for sc, _ in items if sc > FAILED]
    worst = min(ok) if ok else 0.0
    vals = np.array([logsumexp([(sc if sc > FAILED else worst) / T + lp for sc, lp in items])
                     for items in raw.items])
    floor = float(np.min(vals))
    out = np.full(n, floor)
    if raw.phonetic is not None and len(raw.keep) < n and not with_phonetic:
        # a pruned command is at most as likely as the worst aligned one, and less so by as much
        # as the N-best says it is less likely than that one
        ref = float(np.min(raw.phonetic[raw.keep]))
        out = floor + np.minimum(raw.phonetic - ref, 0.0)
    out[raw.keep] = vals
    return out + pool_experts(phon, whisper_term(raw, n, whisper_temperature), pool)


def whisper_term(raw: RawScores, n: int, whisper_temperature: float) -> np.ndarray | float:
    """w / T_w per command; a command Whisper did not score gets the worst scored w (it held almost no mass)."""
    if raw.whisper is None or not len(raw.whisper):
        return 0.0
    w = np.full(n, float(np.min(raw.whisper)))
    w[raw.keep if raw.whisper_keep is None else raw.whisper_keep] = raw.whisper
    return w / whisper_temperature


def align_phrasings(aligner: ForcedAligner, x: np.ndarray, commands: Sequence[RobotCommand],
                    items_of: Callable[[RobotCommand], Sequence[tuple[str, float]]]
                    ) -> tuple[list[list[tuple[float, float]]], int]:
    """(score, log prior) items per command, each of ``items_of(command)``'s phrasings aligned to
    ``x`` by ``aligner`` once per distinct text, and how many distinct texts were aligned."""
    per_cmd: list[list[tuple[str, float]]] = []
    texts: dict[str, None] = {}
    for c in commands:
        items = [(str(t), float(lp)) for t, lp in items_of(c)]
        if not items:
            raise SiftomError(f"no phrasings for command {c}; the phrasing function returned none")
        per_cmd.append(items)
        texts.update(dict.fromkeys(t for t, _ in items))
    unique = list(texts)
    result = aligner.score(x, unique)
    score = dict(zip(unique, result.scores, strict=True))
    return [[(float(score[t]), lp) for t, lp in items] for items in per_cmd], len(unique)
