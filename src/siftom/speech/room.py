"""A speaker across a reverberant room: synthetic room impulse responses, seeded.

``room_impulse_response(rt60, rng)`` is the classic statistical model of a room (Polack):
a direct-path impulse, a few sparse early reflections over the first 50 ms, and a late tail of
Gaussian noise whose energy decays by 60 dB in ``rt60`` seconds, with high frequencies decaying
faster (a one-pole low-pass that closes as the tail ages, as air and walls absorb them). The
direct-to-reverberant ratio ``drr_db`` says how far the talker stands from the microphone
(0 dB: at the critical distance; negative: farther). ``reverberate`` convolves speech with it and
keeps the speech's level, so a dataset mixes noise at the same SNR as for dry speech.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.signal import fftconvolve, lfilter

from siftom.errors import SiftomError
from siftom.speech.audio import SAMPLE_RATE


def room_impulse_response(rt60: float, rng: np.random.Generator | int | None, drr_db: float = -3.0,
                          sr: int = SAMPLE_RATE) -> np.ndarray:
    """A synthetic impulse response of ``1.2 * rt60`` seconds (module doc); its peak is the direct path."""
    if not np.isfinite(rt60) or not 0.05 <= rt60 <= 3.0:
        raise SiftomError(f"rt60 must be between 0.05 and 3 seconds, got {rt60}")
    if not np.isfinite(drr_db):
        raise SiftomError(f"drr_db must be a finite number of dB, got {drr_db}")
    g = np.random.default_rng(rng)
    n = int(1.2 * rt60 * sr)
    t = np.arange(n) / sr
    tail = g.standard_normal(n) * np.exp(-6.9078 * t / rt60)  # 60 dB energy decay over rt60 (amplitude: 3*ln10)
    # frequency-dependent decay: low-pass the tail in blocks, closing with age
    out = np.zeros(n)
    block = max(1, sr // 50)
    for s in range(0, n, block):
        a = min(0.95, 0.2 + 0.75 * (s / max(n, 1)) ** 0.5)
        seg = tail[s:s + block]
        out[s:s + block] = lfilter([1 - a], [1, -a], seg)
    onset = int(0.003 * sr)  # the tail starts a few ms after the direct sound
    out[:onset] = 0.0
    for _ in range(6):  # early reflections
        k = int(g.uniform(0.004, 0.05) * sr)
        if k < n:
            out[k] += g.uniform(0.2, 0.6) * g.choice([-1.0, 1.0]) * np.exp(-6.9078 * k / sr / rt60)
    rev = float(np.sum(out ** 2))
    direct = np.sqrt(rev * 10 ** (drr_db / 10)) if rev > 0 else 1.0
    out[0] = direct
    return out / direct


def reverberate(x: np.ndarray, rt60: float, rng: np.random.Generator | int | None, drr_db: float = -3.0) -> np.ndarray:
    """``x`` as heard across a room (module doc), float32, same length plus the tail, same RMS level."""
    return convolve_at_level(x, room_impulse_response(rt60, rng, drr_db) if len(x) else np.ones(1), rt60)


def convolve_at_level(x: np.ndarray, h: np.ndarray, rt60: float) -> np.ndarray:
    """``x`` convolved with the impulse response ``h``, cut to its length plus 0.3 x ``rt60`` of
    tail, at ``x``'s RMS level (so noise mixes at the same SNR as for dry speech), float32."""
    x = np.asarray(x, dtype=np.float64)
    if not len(x):
        return x.astype(np.float32)
    y = fftconvolve(x, h)[: len(x) + int(0.3 * rt60 * SAMPLE_RATE)]
    rx, ry = float(np.sqrt(np.mean(x ** 2))), float(np.sqrt(np.mean(y ** 2)))
    if ry > 0:
        y *= rx / ry
    peak = float(np.max(np.abs(y)))
    if peak > 0.99:
        y *= 0.99 / peak
    out: npt.NDArray[np.float32] = y.astype(np.float32)
    return out
