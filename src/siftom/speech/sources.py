"""Live audio sources as iterators of 16 kHz mono float32 chunks: a microphone (PortAudio through
``sounddevice``) or a file played as if it were one."""

from __future__ import annotations

import queue
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any, cast

import numpy as np

from siftom.errors import AudioError, BackendUnavailableError
from siftom.speech.audio import SAMPLE_RATE, load_audio

CHUNK_S = 0.02  # 20 ms: what a microphone callback typically delivers
MAX_FILE_S = 3600.0


def file_chunks(path: str | Path, realtime: bool = False, chunk_s: float = CHUNK_S,
                tail_s: float = 1.0) -> Iterator[np.ndarray]:
    """The file's samples in ``chunk_s`` chunks; with ``realtime`` each chunk is released when it
    would have been spoken. ``tail_s`` of silence follow, as a microphone keeps recording after
    the person stops (so the detector can see the end of the last utterance)."""
    x = load_audio(path, max_seconds=MAX_FILE_S)  # read now: a bad file fails before listening starts
    x = np.concatenate([x, np.zeros(int(tail_s * SAMPLE_RATE), dtype=np.float32)])
    return _paced(x, max(1, int(chunk_s * SAMPLE_RATE)), realtime)


def _paced(x: np.ndarray, step: int, realtime: bool) -> Iterator[np.ndarray]:
    t0 = time.perf_counter()
    for k in range(0, len(x), step):
        if realtime:
            time.sleep(max(0.0, t0 + k / SAMPLE_RATE - time.perf_counter()))
        yield x[k:k + step]


def _sounddevice() -> ModuleType:
    try:
        import sounddevice as sd
    except ModuleNotFoundError:
        raise BackendUnavailableError('--mic needs sounddevice: pip install "siftom[stream]"') from None
    except OSError as exc:  # the wheel is there but the PortAudio library is not
        raise BackendUnavailableError(f"--mic needs the PortAudio library ({exc}): on Debian/Ubuntu "
                                      "sudo apt-get install -y libportaudio2; or stream a file with --wav FILE "
                                      "--realtime") from None
    return cast(ModuleType, sd)  # untyped: imported as Any


def list_input_devices() -> list[str]:
    """Names of the input devices PortAudio sees (for error messages and ``--device``)."""
    sd = _sounddevice()
    return [f"{i}: {d['name']}" for i, d in enumerate(sd.query_devices()) if d.get("max_input_channels", 0) > 0]


def mic_chunks(device: int | str | None = None, chunk_s: float = CHUNK_S,
               seconds: float | None = None) -> Iterator[np.ndarray]:
    """Microphone audio until ``seconds`` have been read (None: until interrupted). The device's
    own rate is resampled to 16 kHz and its channels averaged."""
    sd = _sounddevice()
    try:
        info = sd.query_devices(device, "input")
    except (ValueError, sd.PortAudioError) as exc:
        try:
            have = "; ".join(list_input_devices()) or "none"
        except Exception:
            have = "unknown"
        raise AudioError(f"no usable input device {device if device is not None else '(default)'}: {exc}; "
                         f"input devices: {have}; pick one with --device, or use --wav FILE --realtime") from None
    rate = int(info["default_samplerate"]) or SAMPLE_RATE
    channels = max(1, min(2, int(info["max_input_channels"])))
    q: queue.Queue[np.ndarray] = queue.Queue()

    def callback(indata: np.ndarray, frames: int, t: Any, status: Any) -> None:  # PortAudio's time, flags
        q.put(np.asarray(indata, dtype=np.float32).mean(axis=1).copy())

    import soxr

    resampler = soxr.ResampleStream(rate, SAMPLE_RATE, 1, dtype="float32") if rate != SAMPLE_RATE else None
    read = 0
    try:
        stream = sd.InputStream(device=device, channels=channels, samplerate=rate, dtype="float32",
                                blocksize=max(1, int(chunk_s * rate)), callback=callback)
    except sd.PortAudioError as exc:
        raise AudioError(f"cannot open the microphone ({exc}); pick another with --device") from None
    with stream:
        while seconds is None or read < seconds * SAMPLE_RATE:
            x = q.get()
            y = resampler.resample_chunk(x) if resampler is not None else x
            read += len(y)
            if len(y):
                yield y
