"""Background noise and mixing at a target signal-to-noise ratio.

SNR is measured over *active speech*: the speech is cut into 20 ms frames, frames whose energy
is within ``VAD_RANGE_DB`` (40 dB) of the loudest frame count as active, and

    SNR = 10 log10( mean(speech² over active frames) / mean(noise² over the same frames) ).

Leading and trailing silence in the TTS output therefore does not lower the speech level (as it
would with a whole-file SNR); measuring the noise on the same frames makes the target exact for
non-stationary noise too. After scaling, if the mixture would clip, speech and noise are scaled
down together (the SNR is unchanged). Everything random takes a ``numpy.random.Generator`` or a
seed, so the same seed gives the same mixture bit for bit.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from siftom.errors import AudioError, SiftomError, unknown_name
from siftom.speech.audio import SAMPLE_RATE, load_audio

FRAME = SAMPLE_RATE // 50  # 20 ms
VAD_RANGE_DB = 40.0
PEAK_LIMIT = 0.99
SYNTHETIC_KINDS = ("white", "pink", "brown", "babble", "hum")
_NOISE_MAX_SECONDS = 900.0
# Real household recordings shipped with the package (manifest and licences in its README.md).
RECORDED_NOISE_DIR = Path(str(resources.files("siftom.data").joinpath("noise")))

Rng = np.random.Generator | int | None


SNR_RANGE_DB = (-50.0, 100.0)  # the SNRs a mix takes (beyond: silence or noise alone, or float overflow)


def make_rng(rng: Rng) -> np.random.Generator:
    """A Generator from a seed (a whole number >= 0), an existing Generator, or None (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, int | np.integer) and rng < 0:
        raise AudioError(f"a seed is a whole number >= 0, got {rng}; give e.g. --seed 0")
    return np.random.default_rng(rng)


@runtime_checkable
class NoiseSource(Protocol):
    """Anything that can produce ``n`` samples of 16 kHz noise."""

    @property
    def name(self) -> str:
        """What the noise is called (a kind or a file name)."""
        ...

    def sample(self, n: int, rng: Rng = None) -> np.ndarray:
        """Return ``n`` float32 samples."""
        ...


def active_mask(speech: np.ndarray, range_db: float = VAD_RANGE_DB) -> np.ndarray:
    """Boolean per-sample mask of active speech (energy VAD on 20 ms frames, see module doc)."""
    x = np.asarray(speech, dtype=np.float64)
    n_frames = max(1, int(np.ceil(len(x) / FRAME)))
    padded = np.zeros(n_frames * FRAME)
    padded[: len(x)] = x
    energy = (padded.reshape(n_frames, FRAME) ** 2).mean(axis=1)
    peak = energy.max()
    if peak <= 1e-12:
        raise AudioError("the speech is silent (no frame above -120 dBFS); cannot set an SNR")
    active = energy >= peak * 10.0 ** (-range_db / 10.0)
    return np.repeat(active, FRAME)[: len(x)]


def measure_snr(speech: np.ndarray, noise: np.ndarray, mask: np.ndarray | None = None) -> float:
    """SNR in dB of ``speech`` over ``noise`` on active-speech frames (module doc)."""
    if len(speech) != len(noise):
        raise SiftomError(f"speech and noise lengths differ ({len(speech)} vs {len(noise)})")
    m = active_mask(speech) if mask is None else mask
    ps = float(np.mean(np.asarray(speech, np.float64)[m] ** 2))
    pn = float(np.mean(np.asarray(noise, np.float64)[m] ** 2))
    if pn <= 0.0:
        return float("inf")
    snr: float = 10.0 * np.log10(ps / pn)
    return snr


def scale_noise(speech: np.ndarray, noise: np.ndarray, snr_db: float) -> np.ndarray:
    """Return ``noise`` scaled so that ``measure_snr(speech, result) == snr_db``."""
    if not np.isfinite(snr_db):
        raise SiftomError(f"snr_db must be a finite number of dB, got {snr_db}")
    if len(noise) != len(speech):
        raise SiftomError(f"speech and noise lengths differ ({len(speech)} vs {len(noise)})")
    m = active_mask(speech)
    ps = float(np.mean(np.asarray(speech, np.float64)[m] ** 2))
    pn = float(np.mean(np.asarray(noise, np.float64)[m] ** 2))
    if pn <= 1e-20:
        raise AudioError("the noise is silent where the speech is; choose another noise clip")
    gain = np.sqrt(ps / (pn * 10.0 ** (snr_db / 10.0)))
    scaled: npt.NDArray[np.float64] = np.asarray(noise, np.float64) * gain
    return scaled


def mix_at_snr(
    speech: np.ndarray, noise: np.ndarray | NoiseSource, snr_db: float, rng: Rng = None
) -> np.ndarray:
    """Add noise to speech at ``snr_db`` (over active speech) with clip protection.

    Args:
        speech: 16 kHz mono float samples.
        noise: samples (looped or cut from a random offset to the speech length) or a NoiseSource.
        snr_db: target SNR in dB.
        rng: seed or Generator for the noise excerpt; the same seed gives identical output.
    """
    if not SNR_RANGE_DB[0] <= snr_db <= SNR_RANGE_DB[1]:  # also NaN: no comparison holds
        raise AudioError(f"an SNR of {snr_db} dB is outside {SNR_RANGE_DB[0]:g} to {SNR_RANGE_DB[1]:g} dB (beyond, "
                         "the mix is the noise or the speech alone); give e.g. --snr 10")
    gen = make_rng(rng)
    s = np.asarray(speech, np.float64)
    if s.ndim != 1 or s.size == 0:
        raise AudioError("speech must be a non-empty 1-D array of 16 kHz samples")
    if isinstance(noise, NoiseSource):
        n = np.asarray(noise.sample(len(s), gen), np.float64)
    else:
        n = fit_length(np.asarray(noise, np.float64), len(s), gen)
    mixed = s + scale_noise(s, n, snr_db)
    peak = float(np.max(np.abs(mixed)))
    if peak > PEAK_LIMIT:  # scale speech and noise together: the SNR stays the same
        mixed *= PEAK_LIMIT / peak
    out: npt.NDArray[np.float32] = mixed.astype(np.float32)
    return out


def fit_length(noise: np.ndarray, n: int, rng: Rng = None) -> np.ndarray:
    """Cut ``n`` samples from a random offset, looping the clip when it is shorter."""
    x = np.asarray(noise)
    if x.ndim != 1 or x.size == 0:
        raise AudioError("noise must be a non-empty 1-D array of 16 kHz samples")
    gen = make_rng(rng)
    start = int(gen.integers(0, len(x)))
    reps = int(np.ceil((start + n) / len(x)))
    return np.tile(x, reps)[start : start + n]


@dataclass(frozen=True)
class SyntheticNoise:
    """Generated noise: white, pink (1/f), brown (1/f²), babble (synthesised talkers) or hum."""

    kind: str

    def __post_init__(self) -> None:
        if self.kind not in SYNTHETIC_KINDS:
            raise unknown_name("synthetic noise", self.kind, SYNTHETIC_KINDS)

    @property
    def name(self) -> str:
        """The kind, used as the registry name."""
        return self.kind

    def sample(self, n: int, rng: Rng = None) -> np.ndarray:
        """Return ``n`` samples with unit-ish RMS (the level is set by ``mix_at_snr``)."""
        gen = make_rng(rng)
        if self.kind == "white":
            x = gen.standard_normal(n)
        elif self.kind in ("pink", "brown"):
            x = _coloured(gen.standard_normal(n), 1.0 if self.kind == "pink" else 2.0)
        elif self.kind == "hum":
            x = _hum(n, gen)
        else:
            x = fit_length(_babble_bed(), n, gen)
        rms = float(np.sqrt(np.mean(x**2))) or 1.0
        return (0.1 * x / rms).astype(np.float32)


def _coloured(white: np.ndarray, exponent: float) -> np.ndarray:
    """Shape white noise to a 1/f^exponent power spectrum (DC removed)."""
    spec = np.fft.rfft(white)
    f = np.fft.rfftfreq(len(white), 1.0 / SAMPLE_RATE)
    f[0] = f[1] if len(f) > 1 else 1.0
    spec *= f ** (-exponent / 2.0)
    spec[0] = 0.0
    return np.fft.irfft(spec, n=len(white))


def _hum(n: int, gen: np.random.Generator) -> np.ndarray:
    """Mains hum (50 or 60 Hz) with decaying harmonics and a little broadband motor noise."""
    base = float(gen.choice([50.0, 60.0]))
    t = np.arange(n) / SAMPLE_RATE
    x = np.zeros(n)
    for k in range(1, 16):
        x += (0.7**k) * np.sin(2 * np.pi * base * k * t + gen.uniform(0, 2 * np.pi))
    motor = _coloured(gen.standard_normal(n), 1.0)
    return x + 0.05 * motor / (float(np.std(motor)) or 1.0)


# Talkers for babble: (voice, pitch, rate, line). The test voices' own default settings are
# avoided so that the babble is never the target speaker talking over themselves.
_BABBLE_TALKERS = (
    ("flite-rms", 0.8, 1.1, "I think we should leave a bit earlier tomorrow morning"),
    ("flite-awb", 1.15, 0.95, "did you see the match last night it was really something"),
    ("espeak-en-us+klatt2", 0.85, 1.1, "the price of vegetables has gone up again this week"),
    ("espeak-de", 1.1, 1.0, "she said the train was late because of the weather"),
    ("flite-slt", 1.3, 1.15, "could you remind me what time the meeting starts"),
    ("espeak-en-gb", 0.9, 0.9, "we are out of coffee so I will buy some later"),
    ("espeak-es", 1.2, 1.05, "my brother is moving to a new flat next month"),
    ("flite-kal16", 1.2, 0.9, "the children are playing in the garden all afternoon"),
    ("espeak-en-us+f3", 0.9, 1.1, "the doctor told him to rest for a couple of days"),
    ("espeak-fr", 1.0, 0.95, "there is a new bakery at the end of our street"),
)
BABBLE_TALKERS = 8


@functools.lru_cache(maxsize=1)
def _babble_bed() -> np.ndarray:
    """About 12 s of eight overlapping synthesised talkers (built once per process, ~1 s)."""
    from siftom.speech.tts import engine_available, get_voice, synthesize

    gen = np.random.default_rng(12345)  # fixed: the bed is part of the noise definition
    length = 12 * SAMPLE_RATE
    bed = np.zeros(length)
    talkers = [t for t in _BABBLE_TALKERS if engine_available(get_voice(t[0]).engine)]
    if not talkers:
        raise SiftomError("babble noise needs flite or espeak-ng; sudo apt-get install -y flite espeak-ng")
    gap = np.zeros(int(0.15 * SAMPLE_RATE))
    for i in range(BABBLE_TALKERS):
        # each talker speaks three lines back to back, starting at a random offset
        parts = []
        for j in range(3):
            voice, pitch, rate, line = talkers[(i + 3 * j) % len(talkers)]
            parts += [synthesize(line, voice, rate=rate, pitch=pitch), gap]
        track = np.concatenate(parts)
        track /= float(np.sqrt(np.mean(track**2))) or 1.0
        bed += np.roll(fit_length(track, length, gen), int(gen.integers(0, length)))
    return bed


class FolderNoise:
    """Noise clips from a folder of WAV files (flat, or MS-SNSD style noise_train/noise_test)."""

    def __init__(self, folder: str | Path, split: str | None = None, categories: Sequence[str] = ()) -> None:
        """Index the folder.

        Args:
            folder: a folder of .wav files, or one with noise_train/ and noise_test/ subfolders.
            split: ``train`` or ``test`` to pick a subfolder (default: train when it exists).
            categories: keep only files whose name starts with one of these (``babble``).
        """
        root = Path(folder)
        if not root.is_dir():
            raise AudioError(f"noise folder {str(root)!r} does not exist; give a folder of WAV files")
        sub = root / f"noise_{split or 'train'}"
        if split is not None and not sub.is_dir():
            raise AudioError(f"noise folder {str(root)!r} has no noise_{split}/ subfolder")
        base = sub if sub.is_dir() else root
        files = sorted(p for p in base.iterdir() if p.suffix.lower() == ".wav")
        if categories:
            files = [p for p in files if p.name.lower().startswith(tuple(c.lower() for c in categories))]
        if not files:
            what = f" matching {', '.join(categories)}" if categories else ""
            raise AudioError(f"no .wav files{what} in {str(base)!r}; add noise recordings there")
        self.files = tuple(files)
        self.name = f"{root.name}" + (f":{','.join(categories)}" if categories else "")

    def sample(self, n: int, rng: Rng = None) -> np.ndarray:
        """Pick a clip at random and cut ``n`` samples from a random offset (looping)."""
        gen = make_rng(rng)
        path = self.files[int(gen.integers(0, len(self.files)))]
        return fit_length(_load_noise(str(path)), n, gen)


@functools.lru_cache(maxsize=64)
def _load_noise(path: str) -> np.ndarray:
    x = load_audio(path, max_seconds=_NOISE_MAX_SECONDS)
    if float(np.max(np.abs(x))) == 0.0:
        raise AudioError(f"noise file {path!r} is silent; remove it from the folder")
    return x


class FileNoise:
    """A single noise WAV file."""

    def __init__(self, path: str | Path) -> None:
        """Remember the file; it is loaded on first use."""
        self.path = Path(path)
        if not self.path.is_file():
            raise AudioError(f"noise file {str(self.path)!r} does not exist")
        self.name = self.path.stem

    def sample(self, n: int, rng: Rng = None) -> np.ndarray:
        """Cut ``n`` samples from a random offset (looping)."""
        return fit_length(_load_noise(str(self.path)), n, make_rng(rng))


def get_noise(spec: str | Path | NoiseSource) -> NoiseSource:
    """Resolve a noise spec: a synthetic kind, a WAV file, a folder, or ``FOLDER:category``.

    ``recorded`` (or ``recorded:babble,dishes``) is the real recordings shipped with siftom.
    """
    if isinstance(spec, NoiseSource):
        return spec
    s = str(spec)
    if s in SYNTHETIC_KINDS:
        return SyntheticNoise(s)
    if s == "recorded" or s.startswith("recorded:"):
        cats = s.partition(":")[2]
        return FolderNoise(RECORDED_NOISE_DIR, categories=tuple(c for c in cats.split(",") if c))
    p = Path(s)
    if p.is_file():
        return FileNoise(p)
    if p.is_dir():
        return FolderNoise(p)
    if ":" in s:
        folder, cats = s.rsplit(":", 1)
        if Path(folder).is_dir():
            return FolderNoise(folder, categories=tuple(c for c in cats.split(",") if c))
    if "/" in s or s.endswith(".wav"):
        raise AudioError(f"noise path {s!r} does not exist; give a WAV file or a folder of them")
    raise unknown_name("noise", s, SYNTHETIC_KINDS)
