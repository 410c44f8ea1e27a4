"""TTS voices: registry, names, and real synthesis."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from siftom.errors import SiftomError, UnknownNameError
from siftom.speech.tts import DEFAULT_VOICE, get_voice, list_voices, synthesize

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
needs_espeak = pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")


def test_registry_has_both_kinds_and_accents():
    voices = list_voices()
    engines = {v.engine for v in voices}
    assert engines == {"flite", "espeak-ng"}
    assert {"es", "de", "hi", "fr"} <= {v.accent for v in voices}
    assert any("+klatt" in v.name for v in voices)
    assert get_voice(DEFAULT_VOICE).engine == "flite"


def test_unknown_voice_suggests_close_names():
    with pytest.raises(UnknownNameError, match="flite-slt"):
        get_voice("flite-sl")


@needs_flite
def test_flite_voice_gives_16k_float(cereal_clip):
    assert cereal_clip.dtype == np.float32
    assert 0.8 < len(cereal_clip) / 16000 < 4.0
    assert 0.05 < float(np.max(np.abs(cereal_clip))) <= 1.0


@needs_flite
def test_rate_changes_duration():
    slow = synthesize("pass me the cereal", "flite-rms", rate=0.7)
    fast = synthesize("pass me the cereal", "flite-rms", rate=1.4)
    assert len(slow) > 1.5 * len(fast)


@needs_espeak
@pytest.mark.parametrize("name", ["espeak-en-us+klatt", "espeak-es", "espeak-hi"])
def test_espeak_voices_speak(name):
    x = synthesize("bring me the milk", name, pitch=1.2)
    assert len(x) > 8000 and float(np.max(np.abs(x))) > 0.05


def test_bad_arguments():
    with pytest.raises(SiftomError, match="empty"):
        synthesize("   ")
    with pytest.raises(SiftomError, match="rate"):
        synthesize("hi", rate=10)
