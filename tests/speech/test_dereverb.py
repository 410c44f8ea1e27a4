"""Single-channel WPE dereverberation: the clip's length and level kept, the same output every
time, a reverberant tail shortened, and the pip line named when nara_wpe is not installed."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from siftom.errors import BackendUnavailableError, SiftomError
from siftom.speech.audio import SAMPLE_RATE
from siftom.speech.room import convolve_at_level, room_impulse_response

SR = SAMPLE_RATE


def vowels(seed: int = 0, seconds: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """Harmonic bursts of random pitch and length with pauses between them (a speech-like source),
    and the mask of the pauses (from 30 ms after each burst ends: where only the tail sounds)."""
    rng = np.random.default_rng(seed)
    x, pause = np.zeros(int(seconds * SR)), np.ones(int(seconds * SR), dtype=bool)
    p = 2000
    while p + 6000 < len(x):
        n, f0 = int(rng.uniform(0.08, 0.2) * SR), rng.uniform(100, 250)
        t = np.arange(n) / SR
        x[p:p + n] = sum(np.sin(2 * np.pi * f0 * k * t) / k for k in range(1, 20)) * np.hanning(n)
        pause[p:p + n + int(0.03 * SR)] = False
        p += n + int(rng.uniform(0.1, 0.25) * SR)
    return 0.1 * x, pause


def pause_share_db(v: np.ndarray, pause: np.ndarray) -> float:
    v = np.asarray(v, dtype=np.float64)
    return float(10 * np.log10(np.sum(v[pause] ** 2) / np.sum(v ** 2)))


@pytest.fixture(scope="module")
def wpe():  # noqa: ANN201
    pytest.importorskip("nara_wpe", reason='pip install "siftom[dereverb]"')
    from siftom.speech.dereverb import dereverberate

    return dereverberate


@pytest.fixture(scope="module")
def reverberant() -> tuple[np.ndarray, np.ndarray]:
    x, pause = vowels()
    y = convolve_at_level(x, room_impulse_response(0.3, 3, drr_db=-3.0), 0.3)[: len(x)]
    return y, pause


def test_same_length_level_and_type(wpe, reverberant) -> None:  # noqa: ANN001
    y, _ = reverberant
    for n in (len(y), len(y) - 77, 9000):
        z = wpe(y[:n])
        assert z.shape == (n,) and z.dtype == np.float32
        assert np.sqrt(np.mean(z.astype(float) ** 2)) == pytest.approx(np.sqrt(np.mean(y[:n].astype(float) ** 2)),
                                                                        rel=1e-3)


def test_deterministic(wpe, reverberant) -> None:  # noqa: ANN001
    y, _ = reverberant
    assert np.array_equal(wpe(y), wpe(y.copy()))


def test_the_reverberant_tail_is_shortened(wpe, reverberant) -> None:  # noqa: ANN001
    y, pause = reverberant
    before, after = pause_share_db(y, pause), pause_share_db(wpe(y), pause)
    assert after < before - 0.4, (before, after)  # measured: -19.1 dB -> -20.1 dB
    assert pause_share_db(wpe(y, taps=20), pause) < after  # a longer filter removes more of it


def test_the_image_source_rooms_tail_is_shortened(wpe) -> None:  # noqa: ANN001
    pytest.importorskip("pyroomacoustics", reason='pip install "siftom[rooms]"')
    from siftom.speech.rooms import reverberate_in_room

    x, pause = vowels(1)
    y = reverberate_in_room(x, "kitchen", 3.0, 1)[: len(x)]
    assert pause_share_db(wpe(y), pause) < pause_share_db(y, pause) - 1.0


def test_short_or_silent_clips_come_back_as_they_are(wpe) -> None:  # noqa: ANN001
    short = np.linspace(-0.1, 0.1, 100, dtype=np.float32)
    assert np.array_equal(wpe(short), short)
    assert np.array_equal(wpe(np.zeros(SR, dtype=np.float32)), np.zeros(SR, dtype=np.float32))
    assert wpe(np.zeros(0, dtype=np.float32)).shape == (0,)


def test_bad_input_is_refused(wpe) -> None:  # noqa: ANN001
    with pytest.raises(SiftomError, match="one channel"):
        wpe(np.zeros((2, SR)))
    with pytest.raises(SiftomError, match="finite"):
        wpe(np.full(SR, np.nan))
    with pytest.raises(SiftomError, match="at least 1"):
        wpe(np.zeros(SR), taps=0)


def test_without_nara_wpe_the_pip_line_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    from siftom.speech.dereverb import dereverberate

    for name in ("nara_wpe", "nara_wpe.wpe", "nara_wpe.utils"):
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(BackendUnavailableError, match=r'pip install "siftom\[dereverb\]"'):
        dereverberate(np.ones(SR, dtype=np.float32))
