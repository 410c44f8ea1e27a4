"""Dereverberation of one microphone: weighted prediction error (WPE), offline, by ``nara_wpe``.

WPE (Nakatani et al. 2010; Yoshioka & Nakatani 2012) predicts each STFT frame's late reverberation
from the ``taps`` frames that ended ``delay`` frames earlier, one linear filter per frequency, and
subtracts it. The filter is fitted by iteratively reweighted least squares, weighting each frame by
the inverse of the current estimate of the dry speech's power (``iterations`` rounds), so the
direct sound and the early reflections (within ``delay`` frames, 24 ms here) are kept and the
tail that smears one word into the next is removed. With one channel the filter cannot null a
direction; it only shortens the tail.

``dereverberate`` works at 16 kHz on a 512-point STFT with a 128-sample shift (32 ms windows,
8 ms hop: ``nara_wpe``'s examples) and returns the clip at its own length and RMS level (so a
level-dependent stage after it, the voice-activity detector's SNR, sees the same level). The
``dereverb`` extra installs ``nara_wpe`` (``pip install "siftom[dereverb]"``); docs/speech.md
"Dereverberation" has what it measured on the rooms sets.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from siftom.errors import SiftomError, missing_extra

STFT_SIZE = 512
STFT_SHIFT = 128
EXTRA = "dereverb"


def _nara_wpe() -> tuple[Any, Any, Any]:
    """(wpe, stft, istft) from ``nara_wpe``, or the pip line that installs it."""
    try:
        from nara_wpe.utils import istft, stft
        from nara_wpe.wpe import wpe
    except ImportError:
        raise missing_extra(EXTRA, "nara-wpe") from None
    return wpe, stft, istft


def dereverberate(x: np.ndarray, *, taps: int = 10, delay: int = 3, iterations: int = 3) -> np.ndarray:
    """``x`` (16 kHz mono) with its late reverberation removed by single-channel WPE (module doc):
    float32, the same length and RMS level; deterministic (no randomness in WPE).

    Args:
        x: the samples, 16 kHz mono.
        taps: frames of the prediction filter (10: 80 ms of past).
        delay: frames skipped before the filter's window (3: the first 24 ms are kept).
        iterations: reweighting rounds of the filter's fit.

    Raises:
        BackendUnavailableError: ``nara_wpe`` is not installed (the ``dereverb`` extra).
        SiftomError: ``x`` is not one channel of finite samples, or an argument is out of range.
    """
    if taps < 1 or delay < 1 or iterations < 1:
        raise SiftomError(f"taps, delay and iterations must be at least 1, got {taps}, {delay}, {iterations}")
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise SiftomError(f"dereverberate takes one channel of samples, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise SiftomError("dereverberate: the samples are not all finite")
    wpe, stft, istft = _nara_wpe()
    rx = float(np.sqrt(np.mean(a ** 2))) if len(a) else 0.0
    if len(a) < STFT_SIZE or rx == 0.0:
        same: npt.NDArray[np.float32] = a.astype(np.float32)  # too short to filter, or silence
        return same
    spec = stft(a[None, :], size=STFT_SIZE, shift=STFT_SHIFT)  # (D=1, T, F)
    y = np.transpose(spec, (2, 0, 1))  # (F, D, T), as wpe wants
    z = wpe(y, taps=taps, delay=delay, iterations=iterations, statistics_mode="full")
    out = np.asarray(istft(np.transpose(z, (1, 2, 0)), size=STFT_SIZE, shift=STFT_SHIFT))[0]
    out = out[: len(a)]
    if len(out) < len(a):
        out = np.pad(out, (0, len(a) - len(out)))
    ry = float(np.sqrt(np.mean(out ** 2)))
    if ry > 0:
        out = out * (rx / ry)
    peak = float(np.max(np.abs(out)))
    if peak > 0.99:
        out = out * (0.99 / peak)
    res: npt.NDArray[np.float32] = out.astype(np.float32)
    return res
