"""Measure the voice-activity detectors: ``python -m siftom.bench.vad [NOISE_DIR]``.

False alarms: every recorded noise file whole, and 3 s excerpts (the first two) of each. Misses: four TTS
sentences (four voices) mixed with every third noise file at 20, 10, 5 and 0 dB (fixed seeds).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from siftom.speech.vad import detect_speech

SENTENCES = (("can you pass me the cereal", "flite-slt"), ("bring me three forks", "flite-rms"),
             ("i need the milk", "espeak-en-us+klatt"), ("could you grab the olive oil please", "espeak-es"))


def main(noise_dir: str | None = None, methods: tuple[str, ...] = ("silero", "spectral")) -> dict:
    """False alarms and misses per detector method (see module doc)."""
    from siftom.speech.audio import load_audio
    from siftom.speech.noise import RECORDED_NOISE_DIR, mix_at_snr
    from siftom.speech.tts import synthesize

    files = sorted(Path(noise_dir or RECORDED_NOISE_DIR).glob("*.wav"))
    noises = {f.stem: load_audio(f) for f in files}
    speech = [synthesize(text, voice) for text, voice in SENTENCES]
    out: dict[str, object] = {"noise_files": len(files)}
    for method in methods:
        whole = [name for name, x in noises.items() if detect_speech(x, method=method).speech]
        alarms, excerpts = [], 0
        for name, x in noises.items():
            for k in range(2):
                seg = x[k * 48_000:(k + 1) * 48_000]
                if len(seg) < 16_000:
                    continue
                excerpts += 1
                if detect_speech(seg, method=method).speech:
                    alarms.append(f"{name}#{k}")
        heard: dict[str, list[int]] = {}
        for i, sp in enumerate(speech):
            for j, f in enumerate(files[::3]):
                for snr in (20, 10, 5, 0):
                    r = detect_speech(mix_at_snr(sp, noises[f.stem], snr, i * 100 + j), method=method)
                    cell = heard.setdefault(f"{snr} dB", [0, 0])
                    cell[0] += int(r.speech)
                    cell[1] += 1
        out[method] = {"whole_clips_with_speech": f"{len(whole)}/{len(noises)}", "whole_clip_files": whole,
                       "excerpts_with_speech": f"{len(alarms)}/{excerpts}", "excerpt_files": alarms,
                       "speech_detected": {k: f"{a}/{n}" for k, (a, n) in heard.items()}}
    return out


if __name__ == "__main__":
    print(json.dumps(main(*sys.argv[1:]), indent=2))
