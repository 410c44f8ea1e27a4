"""Audio loading: every odd input is resampled or refused with a clear AudioError."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.errors import AudioError
from siftom.speech.audio import (
    SAMPLE_RATE,
    as_audio,
    load_audio,
    to_pcm16,
    with_noise_floor,
    write_wav,
)


def _tone(rate: int, seconds: float = 0.5, amp: float = 0.3) -> np.ndarray:
    t = np.arange(int(rate * seconds)) / rate
    return (amp * np.sin(2 * np.pi * 440 * t)).astype(np.float32)


@pytest.mark.parametrize("rate", [8000, 16000, 22050, 44100, 48000])
def test_any_rate_is_resampled_to_16k(tmp_path, rate):
    p = tmp_path / f"t{rate}.wav"
    sf.write(p, _tone(rate), rate)
    x = load_audio(p)
    assert x.dtype == np.float32
    assert abs(len(x) - SAMPLE_RATE // 2) <= 2


def test_stereo_is_downmixed(tmp_path):
    p = tmp_path / "st.wav"
    tone = _tone(44100)
    sf.write(p, np.stack([tone, -0.5 * tone], axis=1), 44100)
    x = load_audio(p)
    assert x.ndim == 1 and abs(len(x) - 8000) <= 2


def test_clipped_float_wav_is_clipped_to_full_scale(tmp_path):
    p = tmp_path / "clip.wav"
    sf.write(p, 3.0 * _tone(16000), 16000, subtype="FLOAT")
    x = load_audio(p)
    assert float(np.max(np.abs(x))) <= 1.0


def test_silent_file_loads_as_zeros(tmp_path):
    p = write_wav(tmp_path / "silent.wav", np.zeros(16000, np.float32))
    assert not np.any(load_audio(p))


@pytest.mark.parametrize(
    ("content", "match"),
    [(b"", "empty"), (b"this is not audio at all" * 10, "not a WAV"), (b"RIFF\x10\x00\x00\x00WAVEfmt ", "corrupt")],
)
def test_bad_files_raise_audio_error(tmp_path, content, match):
    p = tmp_path / "bad.wav"
    p.write_bytes(content)
    with pytest.raises(AudioError, match=match):
        load_audio(p)


def test_header_only_wav_has_no_samples(tmp_path):
    p = tmp_path / "nodata.wav"
    sf.write(p, np.zeros(0, np.float32), 16000)
    with pytest.raises(AudioError, match="no samples"):
        load_audio(p)


def test_missing_file(tmp_path):
    with pytest.raises(AudioError, match="does not exist"):
        load_audio(tmp_path / "nope.wav")


def test_thirty_minute_file_is_refused_before_decoding(tmp_path, monkeypatch):
    p = tmp_path / "long.wav"
    sf.write(p, np.zeros(8000 * 60 * 30, np.int16), 8000)

    def no_decoding(*args, **kwargs):  # the header alone refuses it: no sample is decoded
        raise AssertionError("the samples were decoded")

    monkeypatch.setattr(sf, "read", no_decoding)
    with pytest.raises(AudioError, match="1800 s"):
        load_audio(p)


def test_arrays_are_checked():
    with pytest.raises(AudioError):
        as_audio(np.zeros((2, 100)))
    with pytest.raises(AudioError):
        as_audio(np.array([0.0, np.nan]))
    assert as_audio(np.array([2.0, -2.0])).tolist() == [1.0, -1.0]


def test_pcm16_round_trip():
    x = np.array([0.0, 0.5, -0.5, 1.0], np.float32)
    pcm = np.frombuffer(to_pcm16(x, noise_floor_db=None), "<i2")
    assert pcm.tolist() == [0, 16384, -16384, 32767] or pcm.tolist() == [0, 16383, -16383, 32767]


@settings(max_examples=30, deadline=None)
@given(level=st.floats(1e-3, 0.5), below=st.floats(20.0, 60.0), n=st.integers(4000, 32000))
def test_noise_floor_sits_below_the_speech_level(level: float, below: float, n: int):
    t = np.arange(n) / SAMPLE_RATE
    x = (level * np.sin(2 * np.pi * 220 * t)).astype(np.float32)
    x[: n // 4] = 0.0  # digital silence, as TTS and gated recordings have
    y = with_noise_floor(x, below)
    floor = y[: n // 4]
    rms = float(np.sqrt(np.mean(x.astype(np.float64) ** 2)))
    measured = 20 * np.log10(rms / float(np.sqrt(np.mean(floor.astype(np.float64) ** 2))))
    assert abs(measured - below) < 1.5
    assert np.array_equal(y, with_noise_floor(x, below))  # seeded: same audio, same bytes


def test_noise_floor_leaves_silence_and_pcm_defaults_to_it():
    assert not with_noise_floor(np.zeros(1600, np.float32)).any()
    x = np.zeros(1600, np.float32)
    x[800:] = 0.1
    pcm = np.frombuffer(to_pcm16(x), "<i2")
    assert (pcm[:800] != 0).any()  # the decoder never sees digital silence next to speech
    assert to_pcm16(x) == to_pcm16(x)
    with pytest.raises(AudioError, match="below the speech level"):
        with_noise_floor(x, -3.0)
