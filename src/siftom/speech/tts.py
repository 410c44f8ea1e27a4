"""Speak text with offline voices (espeak-ng, flite and one neural voice) as 16 kHz mono float32.

Voices are registered by name: ``flite-slt``, ``espeak-en-us+klatt``, ``espeak-es`` (a Spanish
voice reading English, standing in for a non-native speaker, as in the paper's data) ...
``list_voices()`` gives them all. Measured with pocketsphinx (`siftom bench asr --voices …`,
WER per voice in docs/speech.md): flite voices and
espeak's ``+klatt`` variants are recognised well; espeak's default and accented voices badly.

``hibari-heart`` is a neural voice (hibari-tts: Kokoro-82M's af_heart distilled into a 7.9 MB ONNX
model, 24 kHz, American English, female) from the extra ``siftom[tts-neural]``. Only the voice
inside the wheel is used: the model is opened by its path in the package, never through
hibari's voice lookup (which downloads its other voices), so it runs with no network.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import shutil
import subprocess
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from siftom.errors import BackendUnavailableError, SiftomError, missing_extra
from siftom.registry import Registry
from siftom.speech.audio import to_mono16k

_TIMEOUT_S = 60.0
_ESPEAK_WPM = 165  # espeak-ng's default speed, the reference for rate=1.0
_ESPEAK_PITCH = 50  # espeak-ng's default pitch (0-99), the reference for pitch=1.0
_FLITE_F0 = {"slt": 160.0, "rms": 100.0, "awb": 110.0, "kal": 105.0, "kal16": 105.0}
HIBARI = "hibari"  # the engine name of hibari-tts's voices (Python, not a program on the PATH)
HIBARI_EXTRA = "tts-neural"
_HIBARI_SPEED = (0.5, 2.0)  # the model's speed input: what it was trained for
_HIBARI_PITCH = (0.5, 2.0)  # F0 scaling of the pulse source (the spectral envelope is kept)
_HIBARI_SEED = 0  # the noise branch's generator: the same text gives the same samples


@dataclass(frozen=True)
class Voice:
    """A named TTS voice.

    Attributes:
        name: registry name, e.g. ``flite-slt``.
        engine: ``flite``, ``espeak-ng`` or ``hibari`` (Python, from ``siftom[tts-neural]``).
        ident: the engine's own voice name (``slt``, ``en-us+klatt``, ``heart``).
        accent: ``native`` or the language of a non-native speaker (``es``, ``de`` ...).
        gender: ``f`` or ``m``.
        description: one line for ``siftom voices``.
    """

    name: str
    engine: str
    ident: str
    accent: str
    gender: str
    description: str

    def to_json(self) -> dict[str, str]:
        """Plain dict for JSON output."""
        return asdict(self)


def _builtin_voices() -> list[Voice]:
    v: list[Voice] = [
        Voice("flite-slt", "flite", "slt", "native", "f", "flite CMU ARCTIC slt, US English"),
        Voice("flite-rms", "flite", "rms", "native", "m", "flite CMU ARCTIC rms, US English"),
        Voice("flite-awb", "flite", "awb", "native", "m", "flite CMU ARCTIC awb, Scottish English"),
        Voice("flite-kal16", "flite", "kal16", "native", "m", "flite kal diphone, 16 kHz"),
        Voice("flite-kal", "flite", "kal", "native", "m", "flite kal diphone, 8 kHz (telephone band)"),
    ]
    natives = [
        ("en-us", "m", "espeak-ng US English (formant, robotic)"),
        ("en-gb", "m", "espeak-ng British English (formant, robotic)"),
        ("en-us+klatt", "m", "espeak-ng US English, Klatt synthesiser"),
        ("en-us+klatt2", "m", "espeak-ng US English, Klatt variant 2"),
        ("en-us+klatt4", "f", "espeak-ng US English, Klatt variant 4"),
        ("en-gb+klatt", "m", "espeak-ng British English, Klatt synthesiser"),
        ("en-us+f3", "f", "espeak-ng US English, female variant"),
    ]
    v += [Voice(f"espeak-{i}", "espeak-ng", i, "native", g, d) for i, g, d in natives]
    accents = {"es": "Spanish", "de": "German", "hi": "Hindi", "fr": "French"}
    for code, lang in accents.items():
        v.append(Voice(f"espeak-{code}", "espeak-ng", code, code, "m", f"espeak-ng {lang} voice reading English"))
        v.append(
            Voice(f"espeak-{code}+klatt", "espeak-ng", f"{code}+klatt", code, "m",
                  f"espeak-ng {lang} voice reading English, Klatt synthesiser")
        )
    v.append(Voice("hibari-heart", HIBARI, "heart", "native", "f",
                   "neural (hibari-tts, Kokoro af_heart distilled), US English; siftom[tts-neural]"))
    return v


DEFAULT_VOICE = "flite-slt"
VOICES = Registry("voice", default=DEFAULT_VOICE)


def register_voice(voice: Voice) -> None:
    """Register a voice: its TTS program must be on the PATH (or, for hibari, its extra installed)."""
    if voice.engine == HIBARI:
        VOICES.register(voice.name, "siftom.speech.tts:Voice", summary=voice.description,
                        requires=("hibari", "onnxruntime"), extra=HIBARI_EXTRA, attrs={"voice": voice})
        return
    VOICES.register(voice.name, "siftom.speech.tts:Voice", summary=voice.description,
                    binaries=(voice.engine,), attrs={"voice": voice})


for _v in _builtin_voices():
    register_voice(_v)


def list_voices(available_only: bool = False) -> list[Voice]:
    """All registered voices (in registration order), or only those whose engine is installed."""
    entries = VOICES.entries().values()
    return [e.attrs["voice"] for e in entries if not available_only or e.missing() is None]


def get_voice(name: str | Voice) -> Voice:
    """Look a voice up by name; raise UnknownNameError with close matches."""
    if isinstance(name, Voice):
        return name
    voice: Voice = VOICES.spec(name).attrs["voice"]
    return voice


def engine_available(engine: str) -> bool:
    """Whether the TTS program is on PATH (for ``hibari``: whether siftom[tts-neural] is installed)."""
    if engine == HIBARI:
        return all(importlib.util.find_spec(m) is not None for m in ("hibari", "onnxruntime"))
    return shutil.which(engine) is not None


@functools.lru_cache(maxsize=4)
def _hibari_model(ident: str) -> object:
    """hibari's synthesiser for a voice shipped inside the package (loaded once per process).

    The model is opened by its path in the wheel (``Hibari(model=...)``): ``Hibari(voice=...)``
    would go through ``hibari.voices.voice_path``, which downloads voices that are not bundled.
    """
    try:
        from hibari import Hibari
        from hibari.voices import ASSETS
        from hibari.voices import VOICES as HIBARI_VOICES
    except ImportError:
        raise missing_extra(HIBARI_EXTRA, "hibari-tts") from None
    info = HIBARI_VOICES.get(ident)
    if info is None or not info.get("bundled"):
        raise SiftomError(f"hibari voice {ident!r} is not inside the hibari-tts package; siftom uses only "
                          "bundled voices (the others are downloaded at run time)")
    path = os.path.join(ASSETS, info["file"])
    if not os.path.isfile(path):
        raise BackendUnavailableError(f"hibari-tts is installed without its model file {path}; reinstall it "
                                      f'with: pip install --force-reinstall "siftom[{HIBARI_EXTRA}]"')
    return Hibari(model=path, threads=1)


def _hibari_check_range(v: Voice, rate: float, pitch: float) -> None:
    for what, x, (lo, hi) in (("rate", rate, _HIBARI_SPEED), ("pitch", pitch, _HIBARI_PITCH)):
        if not lo <= x <= hi:
            raise SiftomError(f"the voice {v.name!r} takes {what} within {lo}..{hi}, got {x}")


def _hibari_speak(v: Voice, text: str, rate: float, pitch: float) -> np.ndarray:
    """hibari at 24 kHz -> 16 kHz. ``rate`` is the model's speed input; ``pitch`` scales the F0 of
    its pulse source (the spectral envelope, hence the formants, stays). Fixed noise seed.

    This is ``Hibari.from_ids`` with the F0 scaled between the network and the vocoder (hibari
    0.2.x; the extra pins it below 0.3)."""
    tts: Any = _hibari_model(v.ident)
    from hibari import SAMPLE_RATE, dsp

    rng = np.random.default_rng(_HIBARI_SEED)
    parts = []
    for ps in tts.phonemize(text):
        ids = tts.ids(ps)
        if len(ids) < 3:
            continue
        out = tts.sess.run(None, {"ids": np.asarray([ids], np.int64), "speed": np.asarray([rate], np.float32)})
        lh, th, ln, lr, phi, f0 = (o[0] for o in out)
        parts.append(dsp.synth(lh, th, ln, lr, phi, f0 * np.float32(pitch), rng))
    if not parts:
        raise SiftomError(f"the voice {v.name!r} found nothing to say in {text[:60]!r}")
    return to_mono16k(np.concatenate(parts), int(SAMPLE_RATE))


def synthesize(text: str, voice: str | Voice = DEFAULT_VOICE, rate: float = 1.0, pitch: float = 1.0) -> np.ndarray:
    """Speak ``text`` and return 16 kHz mono float32 samples.

    Args:
        text: what to say (plain English).
        voice: a registered voice name (see ``list_voices``).
        rate: speaking-rate multiplier (1.0 = the voice's default, 1.2 = 20 % faster).
        pitch: pitch multiplier (1.0 = default).
    """
    v = get_voice(voice)
    text = " ".join(str(text).split())
    if not text:
        raise SiftomError("nothing to say: the text is empty")
    if not 0.3 <= rate <= 3.0:
        raise SiftomError(f"rate must be within 0.3..3.0 (1.0 = normal), got {rate}")
    if not 0.3 <= pitch <= 3.0:
        raise SiftomError(f"pitch must be within 0.3..3.0 (1.0 = normal), got {pitch}")
    if v.engine == HIBARI:
        _hibari_check_range(v, rate, pitch)
        if not engine_available(HIBARI):
            raise missing_extra(HIBARI_EXTRA, "hibari-tts")
        return _hibari_speak(v, text, rate, pitch)
    if not engine_available(v.engine):
        raise BackendUnavailableError(
            f"{v.engine} is not installed; install it with: sudo apt-get install -y {v.engine} "
            "(or run make sysdeps)"
        )
    with tempfile.TemporaryDirectory(prefix="siftom-tts-") as tmp:
        out = Path(tmp) / "say.wav"
        if v.engine == "flite":
            f0 = _FLITE_F0.get(v.ident, 110.0) * pitch
            cmd = ["flite", "-voice", v.ident, "--setf", f"duration_stretch={1.0 / rate:.4f}",
                   "--setf", f"int_f0_target_mean={f0:.1f}", "-t", text, "-o", str(out)]
        else:
            wpm = int(round(_ESPEAK_WPM * rate))
            p = int(np.clip(round(_ESPEAK_PITCH * pitch), 0, 99))
            cmd = ["espeak-ng", "-v", v.ident, "-s", str(wpm), "-p", str(p), "-w", str(out), "--", text]
        try:
            proc = subprocess.run(cmd, capture_output=True, timeout=_TIMEOUT_S, check=False)
        except subprocess.TimeoutExpired:
            raise SiftomError(f"{v.engine} took more than {_TIMEOUT_S:.0f} s; say a shorter text") from None
        if proc.returncode != 0 or not out.is_file() or out.stat().st_size <= 44:
            err = proc.stderr.decode(errors="replace").strip()[:200]
            raise SiftomError(f"{v.engine} failed for voice {v.name!r}: {err or 'no audio written'}")
        data, sr = sf.read(str(out), dtype="float32", always_2d=True)
    return to_mono16k(data, sr)
