"""Noise sources and mixing at a target SNR over active speech."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.errors import AudioError, UnknownNameError
from siftom.speech.audio import wav_bytes, write_wav
from siftom.speech.noise import (
    RECORDED_NOISE_DIR,
    SYNTHETIC_KINDS,
    FolderNoise,
    SyntheticNoise,
    active_mask,
    fit_length,
    get_noise,
    measure_snr,
    mix_at_snr,
    scale_noise,
)

SHARED_NOISE = RECORDED_NOISE_DIR


def _burst(seed: int, n: int = 16000) -> np.ndarray:
    """Silence - a noisy 'speech' burst - silence, like a TTS clip."""
    rng = np.random.default_rng(seed)
    x = np.zeros(n)
    a, b = n // 5, 4 * n // 5
    x[a:b] = rng.standard_normal(b - a) * np.hanning(b - a) * 0.3
    return x


@settings(max_examples=40, deadline=None)
@given(snr=st.floats(-10, 40), seed=st.integers(0, 10_000), level=st.floats(1e-3, 10.0))
def test_scaled_noise_hits_the_target_snr(snr, seed, level):
    speech = _burst(seed)
    noise = np.random.default_rng(seed + 1).standard_normal(len(speech)) * level
    scaled = scale_noise(speech, noise, snr)
    assert abs(measure_snr(speech, scaled) - snr) < 0.5


@settings(max_examples=20, deadline=None)
@given(snr=st.floats(-5, 30), seed=st.integers(0, 1000))
def test_clip_protection_scales_speech_and_noise_together(snr, seed):
    speech = _burst(seed) * 3.0  # loud: the mixture must be scaled down
    noise = np.random.default_rng(seed).standard_normal(len(speech))
    mixed = mix_at_snr(speech, noise, snr, seed).astype(np.float64)
    assert float(np.max(np.abs(mixed))) <= 0.99 + 1e-6
    excerpt = fit_length(noise, len(speech), np.random.default_rng(seed))
    unscaled = speech + scale_noise(speech, excerpt, snr)
    gain = min(1.0, 0.99 / float(np.max(np.abs(unscaled))))
    np.testing.assert_allclose(mixed, gain * unscaled, atol=1e-5)


def test_snr_on_real_tts_within_half_db(cereal_clip):
    src = get_noise("babble")
    for snr in (20.0, 10.0, 0.0):
        scaled = scale_noise(cereal_clip, src.sample(len(cereal_clip), 3), snr)
        assert abs(measure_snr(cereal_clip, scaled) - snr) < 0.5


def test_active_mask_ignores_silence():
    m = active_mask(_burst(0))
    assert not m[:1000].any() and m[8000]
    with pytest.raises(AudioError, match="silent"):
        active_mask(np.zeros(100))


@pytest.mark.parametrize("kind", SYNTHETIC_KINDS)
def test_same_seed_same_bytes(kind, cereal_clip):
    a = wav_bytes(mix_at_snr(cereal_clip, get_noise(kind), 5.0, 42))
    b = wav_bytes(mix_at_snr(cereal_clip, get_noise(kind), 5.0, 42))
    c = wav_bytes(mix_at_snr(cereal_clip, get_noise(kind), 5.0, 43))
    assert a == b
    assert a != c


def test_unknown_noise_name():
    with pytest.raises(UnknownNameError, match="babble"):
        get_noise("babel")
    with pytest.raises(UnknownNameError):
        SyntheticNoise("violet")


def test_flat_and_msnsd_folders(tmp_path):
    rng = np.random.default_rng(0)
    flat = tmp_path / "flat"
    write_wav(flat / "fan_01.wav", 0.1 * rng.standard_normal(8000))
    write_wav(flat / "babble_01.wav", 0.1 * rng.standard_normal(4000))
    (flat / "notes.txt").write_text("not audio")
    assert len(FolderNoise(flat).files) == 2
    assert FolderNoise(flat, categories=("babble",)).sample(10000, 1).shape == (10000,)
    ms = tmp_path / "ms"
    write_wav(ms / "noise_train" / "a.wav", 0.1 * rng.standard_normal(8000))
    write_wav(ms / "noise_test" / "b.wav", 0.1 * rng.standard_normal(8000))
    assert FolderNoise(ms).files[0].name == "a.wav"
    assert FolderNoise(ms, split="test").files[0].name == "b.wav"
    with pytest.raises(AudioError, match="no .wav"):
        FolderNoise(tmp_path / "ms" / "noise_train", categories=("rain",))
    with pytest.raises(AudioError, match="does not exist"):
        get_noise(str(tmp_path / "missing" / "x.wav"))


@pytest.mark.skipif(not SHARED_NOISE.is_dir(), reason="recorded noise not packaged")
def test_shared_noise_folder(cereal_clip):
    src = get_noise(f"{SHARED_NOISE}:babble")
    mixed = mix_at_snr(cereal_clip, src, 10.0, 0)
    assert mixed.shape == cereal_clip.shape and np.all(np.isfinite(mixed))
    assert len(get_noise(SHARED_NOISE).files) >= 40  # type: ignore[attr-defined]
