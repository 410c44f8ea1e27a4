"""Shared speech fixtures: synthesised clips and engines, built once per test session."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
needs_espeak = pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")

FOODS = ("cereal", "milk", "sugar", "coffee", "tea", "pasta", "flour", "bread")


@pytest.fixture(scope="session")
def cereal_clip() -> np.ndarray:
    """'pass me the cereal' spoken by flite slt, 16 kHz float32."""
    if shutil.which("flite") is None:
        pytest.skip("flite is not installed")
    from siftom.speech.tts import synthesize

    return synthesize("pass me the cereal", "flite-slt")


@pytest.fixture(scope="session")
def vocab_engine():  # noqa: ANN201
    """pocketsphinx with a kitchen-request vocabulary."""
    from siftom.speech.asr.base import get_engine

    return get_engine("pocketsphinx", vocabulary=list(FOODS))


@pytest.fixture(scope="session")
def aligner():  # noqa: ANN201
    """A shared forced aligner."""
    from siftom.speech.acoustic import ForcedAligner

    return ForcedAligner()
