"""Read, check and convert audio: everything inside siftom is 16 kHz mono float32 in [-1, 1]."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import numpy.typing as npt
import soundfile as sf
import soxr

from siftom.errors import AudioError

SAMPLE_RATE = 16_000
FRAME_RATE = 100  # pocketsphinx frames per second (10 ms hop)
DEFAULT_MAX_SECONDS = 120.0  # a spoken instruction; longer files are almost surely a mistake
_CONVERT_HINT = "convert it with: sox IN.xxx -r 16000 -c 1 -b 16 OUT.wav"



def load_audio(path: str | Path, max_seconds: float = DEFAULT_MAX_SECONDS) -> np.ndarray:
    """Read an audio file as 16 kHz mono float32, resampling and downmixing as needed.

    The duration is checked from the header before any sample is decoded, so an hour-long file
    is refused at once. Raise AudioError (saying how to fix it) for a missing, empty, corrupt,
    unreadable or too long file, or one with no samples.
    """
    p = Path(path)
    if not p.is_file():
        raise AudioError(f"audio file {str(p)!r} does not exist; give the path of a WAV file")
    if p.stat().st_size == 0:
        raise AudioError(f"audio file {str(p)!r} is empty (0 bytes); record or synthesise it again")
    try:
        info = sf.info(str(p))
    except (sf.LibsndfileError, RuntimeError, TypeError) as exc:
        raise AudioError(
            f"cannot read {str(p)!r} as audio ({_short(exc)}); it may be corrupt or not a WAV file; "
            f"{_CONVERT_HINT}"
        ) from None
    if info.frames <= 0 or info.samplerate <= 0:
        raise AudioError(f"audio file {str(p)!r} contains no samples; record or synthesise it again")
    duration = info.frames / info.samplerate
    if duration > max_seconds:
        raise AudioError(
            f"audio file {str(p)!r} lasts {duration:.0f} s, more than the {max_seconds:.0f} s allowed "
            "for one instruction; cut out the instruction (e.g. sox IN.wav OUT.wav trim START LENGTH), "
            "or from Python raise the limit: load_audio(path, max_seconds=...)"
        )
    try:
        data, rate = sf.read(str(p), dtype="float32", always_2d=True)
    except (sf.LibsndfileError, RuntimeError) as exc:
        raise AudioError(
            f"cannot decode {str(p)!r} ({_short(exc)}); the file looks truncated or corrupt; "
            f"{_CONVERT_HINT}"
        ) from None
    return to_mono16k(data, rate)


def to_mono16k(data: np.ndarray, rate: int) -> np.ndarray:
    """Downmix (frames, channels) or (frames,) audio at ``rate`` Hz to 16 kHz mono float32."""
    x = np.asarray(data, dtype=np.float32)
    if x.ndim == 2:
        x = x.mean(axis=1, dtype=np.float32)
    if x.ndim != 1:
        raise AudioError(f"audio must be 1-D or (frames, channels), got shape {x.shape}")
    if x.size == 0:
        raise AudioError("the audio contains no samples; record or synthesise it again")
    if not np.all(np.isfinite(x)):
        raise AudioError("the audio contains NaN or infinite samples; re-export it as 16-bit PCM WAV")
    if rate != SAMPLE_RATE:
        x = soxr.resample(x, rate, SAMPLE_RATE, quality="HQ").astype(np.float32)
    # float WAVs may exceed full scale; clip like a converter to 16-bit PCM would
    return np.clip(x, -1.0, 1.0).astype(np.float32, copy=False)


def as_audio(audio: np.ndarray | str | Path, max_seconds: float = DEFAULT_MAX_SECONDS) -> np.ndarray:
    """Accept a path or an array already at 16 kHz mono; return a float32 array."""
    if isinstance(audio, (str, Path)):
        return load_audio(audio, max_seconds=max_seconds)
    x = np.asarray(audio)
    if x.ndim != 1:
        raise AudioError(f"expected 16 kHz mono samples (1-D), got shape {x.shape}; use to_mono16k")
    if x.size == 0:
        raise AudioError("the audio contains no samples; record or synthesise it again")
    if x.size / SAMPLE_RATE > max_seconds:
        raise AudioError(
            f"the audio lasts {x.size / SAMPLE_RATE:.0f} s, more than the {max_seconds:.0f} s allowed "
            "for one instruction; cut out the instruction, or from Python raise the limit: "
            "as_audio(samples, max_seconds=...)"
        )
    if x.dtype == np.int16:
        x = x.astype(np.float32) / 32768.0
    x = x.astype(np.float32, copy=False)
    if not np.all(np.isfinite(x)):
        raise AudioError("the audio contains NaN or infinite samples")
    out: npt.NDArray[np.float32] = np.clip(x, -1.0, 1.0)
    return out


# pocketsphinx recognises studio-clean speech (TTS, or a recording gated to digital silence
# between words) far worse than the same speech over a little background noise: on clean
# stimuli its WER was 14-31 % against 9-17 % with a noise floor added (docs/speech.md,
# "Noise floor"). Real microphones always have one; decoders get one NOISE_FLOOR_DB below the
# clip's RMS level (like the dither of Kaldi's feature extraction, relative to the speech level).
NOISE_FLOOR_DB = 40.0
NOISE_FLOOR_SEED = 0


def with_noise_floor(x: np.ndarray, below_db: float = NOISE_FLOOR_DB, seed: int = NOISE_FLOOR_SEED) -> np.ndarray:
    """``x`` plus Gaussian noise ``below_db`` dB under its RMS level (seeded: same audio, same output).

    Audio that is all zeros is returned unchanged (silence stays silence for the VAD). Noisy
    recordings are unaffected in practice: their own noise is far above a 40 dB floor.
    """
    if below_db < 0:
        raise AudioError(f"the noise floor must lie below the speech level (below_db >= 0), got {below_db}")
    x = np.asarray(x, dtype=np.float32)
    rms = float(np.sqrt(np.mean(np.square(x, dtype=np.float64)))) if x.size else 0.0
    if rms == 0.0:
        return x
    rng = np.random.default_rng(seed)
    return x + rng.normal(0.0, rms * 10.0 ** (-below_db / 20.0), x.size).astype(np.float32)


def to_pcm16(x: np.ndarray, noise_floor_db: float | None = NOISE_FLOOR_DB) -> bytes:
    """16-bit little-endian PCM bytes for pocketsphinx, with a noise floor (None: the samples as given)."""
    if noise_floor_db is not None:
        x = with_noise_floor(x, noise_floor_db)
    pcm: bytes = (np.clip(x, -1.0, 1.0) * 32767.0).round().astype("<i2").tobytes()
    return pcm


def write_wav(path: str | Path, x: np.ndarray, rate: int = SAMPLE_RATE) -> Path:
    """Write 16-bit PCM mono WAV; create the parent folder."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    sf.write(str(p), np.clip(x, -1.0, 1.0), rate, subtype="PCM_16", format="WAV")
    return p


def wav_bytes(x: np.ndarray, rate: int = SAMPLE_RATE) -> bytes:
    """The bytes of a 16-bit PCM mono WAV file."""
    buf = io.BytesIO()
    sf.write(buf, np.clip(x, -1.0, 1.0), rate, subtype="PCM_16", format="WAV")
    return buf.getvalue()


def duration_s(x: np.ndarray) -> float:
    """Duration in seconds of 16 kHz samples."""
    return float(len(x)) / SAMPLE_RATE


def _short(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return text[:160]
