"""Speak text with offline voices (espeak-ng and flite) as 16 kHz mono float32.

Voices are registered by name: ``flite-slt``, ``espeak-en-us+klatt``, ``espeak-es`` (a Spanish
voice reading English, standing in for a non-native speaker, as in the paper's data) ...
``list_voices()`` gives them all. Measured with pocketsphinx (`siftom bench asr --voices …`,
WER per voice in docs/speech.md): flite voices and
espeak's ``+klatt`` variants are recognised well; espeak's default and accented voices badly.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import soundfile as sf

from siftom.errors import BackendUnavailableError, SiftomError
from siftom.registry import Registry
from siftom.speech.audio import to_mono16k

_TIMEOUT_S = 60.0
_ESPEAK_WPM = 165  # espeak-ng's default speed, the reference for rate=1.0
_ESPEAK_PITCH = 50  # espeak-ng's default pitch (0-99), the reference for pitch=1.0
_FLITE_F0 = {"slt": 160.0, "rms": 100.0, "awb": 110.0, "kal": 105.0, "kal16": 105.0}


@dataclass(frozen=True)
class Voice:
    """A named TTS voice.

    Attributes:
        name: registry name, e.g. ``flite-slt``.
        engine: ``flite`` or ``espeak-ng``.
        ident: the engine's own voice name (``slt``, ``en-us+klatt``).
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
    return v


DEFAULT_VOICE = "flite-slt"
VOICES = Registry("voice", default=DEFAULT_VOICE)


def register_voice(voice: Voice) -> None:
    """Register a voice: its TTS program must be on the PATH to use it."""
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
    """Whether the TTS program is on PATH."""
    return shutil.which(engine) is not None


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
