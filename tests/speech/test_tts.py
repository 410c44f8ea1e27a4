"""TTS voices: registry, names, and real synthesis."""

from __future__ import annotations

import importlib.util
import shutil
import socket

import numpy as np
import pytest

from siftom.errors import BackendUnavailableError, SiftomError, UnknownNameError
from siftom.speech.tts import DEFAULT_VOICE, VOICES, get_voice, list_voices, synthesize

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
needs_espeak = pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")


def test_registry_has_both_kinds_and_accents():
    voices = list_voices()
    engines = {v.engine for v in voices}
    assert engines == {"flite", "espeak-ng", "hibari"}
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


# -- the neural voice (siftom[tts-neural]) ---------------------------------------------------

_HAS_HIBARI = all(importlib.util.find_spec(m) is not None for m in ("hibari", "onnxruntime"))
needs_hibari = pytest.mark.skipif(
    not _HAS_HIBARI, reason='hibari-tts is not installed (pip install "siftom[tts-neural]")')


def test_hibari_voice_is_registered_behind_its_extra():
    v = get_voice("hibari-heart")
    assert (v.engine, v.ident, v.accent, v.gender) == ("hibari", "heart", "native", "f")
    entry = VOICES.spec("hibari-heart")
    assert entry.extra == "tts-neural" and "hibari" in entry.requires and entry.binaries == ()


def test_hibari_missing_extra_names_the_pip_install(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name.split(".")[0] == "hibari" else real(name, *a))
    assert 'pip install "siftom[tts-neural]"' in (VOICES.spec("hibari-heart").missing() or "")
    with pytest.raises(BackendUnavailableError, match=r'pip install "siftom\[tts-neural\]"'):
        synthesize("bring me the milk", "hibari-heart")


def test_hibari_refuses_rates_outside_its_range():
    """Checked before the extra, so this holds without hibari-tts installed too."""
    with pytest.raises(SiftomError, match=r"rate within 0.5..2.0"):
        synthesize("bring me the milk", "hibari-heart", rate=2.5)
    with pytest.raises(SiftomError, match=r"pitch within 0.5..2.0"):
        synthesize("bring me the milk", "hibari-heart", pitch=0.4)


@pytest.fixture()
def no_network(monkeypatch, tmp_path):
    """Any connection attempt fails, and hibari's download cache is an empty folder."""
    def refuse(*args, **kwargs):
        raise OSError("the network is disabled in this test")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    monkeypatch.setenv("HIBARI_HOME", str(tmp_path / "hibari-cache"))


@needs_hibari
def test_hibari_speaks_offline_deterministically(no_network, tmp_path):
    a = synthesize("Could you bring me two plates, please?", "hibari-heart")
    b = synthesize("Could you bring me two plates, please?", "hibari-heart")
    assert a.dtype == np.float32 and a.ndim == 1
    assert 1.0 < len(a) / 16000 < 5.0 and 0.05 < float(np.max(np.abs(a))) <= 1.0
    assert np.array_equal(a, b)
    assert not (tmp_path / "hibari-cache").exists()  # nothing was fetched or cached


@needs_hibari
def test_hibari_rate_and_pitch(no_network):
    slow = synthesize("pass me the cereal", "hibari-heart", rate=0.7)
    fast = synthesize("pass me the cereal", "hibari-heart", rate=1.4)
    assert len(slow) > 1.5 * len(fast)
    low = synthesize("pass me the cereal", "hibari-heart", pitch=0.9)
    high = synthesize("pass me the cereal", "hibari-heart", pitch=1.1)
    assert len(low) == len(high) and not np.array_equal(low, high)
