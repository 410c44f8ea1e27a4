"""Spoken instructions offline: TTS voices, noise at an SNR, ASR with N-best, acoustic scoring.

Pipeline stages, one module each: ``tts`` (text -> 16 kHz samples), ``noise`` (mix at an SNR),
``asr`` (samples -> Transcript with N-best), ``acoustic`` (forced-alignment scores of
candidate sentences; wrapped as an instruction likelihood in siftom.likelihood.acoustic).
"""

from __future__ import annotations

from siftom.speech.asr.base import ASREngine, Transcript, Word, get_engine
from siftom.speech.audio import SAMPLE_RATE, load_audio, write_wav
from siftom.speech.noise import get_noise, measure_snr, mix_at_snr
from siftom.speech.tts import Voice, list_voices, synthesize

__all__ = [
    "SAMPLE_RATE",
    "ASREngine",
    "Transcript",
    "Voice",
    "Word",
    "get_engine",
    "get_noise",
    "list_voices",
    "load_audio",
    "measure_snr",
    "mix_at_snr",
    "synthesize",
    "write_wav",
]
