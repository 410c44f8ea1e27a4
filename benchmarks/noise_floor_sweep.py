"""1-best WER of the default scene engine with and without a noise floor under the speech.

Run: .venv/bin/python benchmarks/noise_floor_sweep.py DATASET [CONDITION]   (default: clean)
CONDITION is a dataset condition ("clean") or an SNR suffix ("20dB" matches "babble@20dB").
Prints the mean WER with no floor, a fixed 16-LSB dither, and floors 50/40/30 dB under the
clip's RMS level (docs/speech.md, "Noise floor").
"""

from __future__ import annotations

import functools
import sys

import numpy as np

import siftom.speech.asr.pocketsphinx as ps_engine
from siftom.bench.stimuli import load_dataset
from siftom.bench.trials import dataset_vocabulary
from siftom.speech.asr.base import get_engine
from siftom.speech.audio import as_audio, to_pcm16, with_noise_floor
from siftom.speech.metrics import wer


def _lsb(x: np.ndarray, lsb: float) -> np.ndarray:
    return x + np.random.default_rng(0).normal(0.0, lsb / 32768, x.size).astype(np.float32)


def main() -> None:
    ds = load_dataset(sys.argv[1])
    cond = sys.argv[2] if len(sys.argv) > 2 else "clean"
    stims = [s for s in ds.stimuli if s.condition == cond or s.condition.endswith("@" + cond)]
    if not stims:
        raise SystemExit(f"no stimuli with condition {cond!r} in {sys.argv[1]}")
    # the sweep applies each floor itself: the engine must pass the samples through unchanged
    ps_engine.to_pcm16 = functools.partial(to_pcm16, noise_floor_db=None)
    engine = get_engine("pocketsphinx-vocab", vocabulary=dataset_vocabulary(ds.stimuli))
    variants = {
        "none": lambda x: x,
        "16 LSB": lambda x: _lsb(x, 16),
        "-50 dB": lambda x: with_noise_floor(x, 50),
        "-40 dB": lambda x: with_noise_floor(x, 40),
        "-30 dB": lambda x: with_noise_floor(x, 30),
    }
    errs: dict[str, list[float]] = {k: [] for k in variants}
    for s in stims:
        x = as_audio(ds.audio_path(s))
        for k, f in variants.items():
            errs[k].append(wer(s.reference, engine.transcribe(f(x)).text))
    print(f"{sys.argv[1]} {cond} n={len(stims)} " + "  ".join(f"{k}: {100 * np.mean(v):.1f}" for k, v in errs.items()))


if __name__ == "__main__":
    main()
