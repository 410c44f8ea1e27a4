"""Measure the voice-activity detector: ``python -m siftom.bench.vad [NOISE_DIR]``.

False alarms: 3 s excerpts (the first two) of every recorded noise file. Misses: four TTS
sentences (four voices) mixed with every third noise file at 20, 10, 5 and 0 dB (fixed seeds).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from siftom.speech.vad import detect_speech

SENTENCES = (("can you pass me the cereal", "flite-slt"), ("bring me three forks", "flite-rms"),
             ("i need the milk", "espeak-en-us+klatt"), ("could you grab the olive oil please", "espeak-es"))


def main(noise_dir: str | None = None) -> dict:
    from siftom.speech.audio import load_audio
    from siftom.speech.noise import RECORDED_NOISE_DIR, mix_at_snr
    from siftom.speech.tts import synthesize

    files = sorted(Path(noise_dir or RECORDED_NOISE_DIR).glob("*.wav"))
    alarms, excerpts = [], 0
    for f in files:
        x = load_audio(f)
        for k in range(2):
            seg = x[k * 48_000:(k + 1) * 48_000]
            if len(seg) < 16_000:
                continue
            excerpts += 1
            if detect_speech(seg).speech:
                alarms.append(f"{f.stem}#{k}")
    heard: dict[str, list[int]] = {}
    for i, (text, voice) in enumerate(SENTENCES):
        sp = synthesize(text, voice)
        for j, f in enumerate(files[::3]):
            for snr in (20, 10, 5, 0):
                r = detect_speech(mix_at_snr(sp, load_audio(f), snr, i * 100 + j))
                heard.setdefault(f"{snr} dB", [0, 0])
                heard[f"{snr} dB"][0] += int(r.speech)
                heard[f"{snr} dB"][1] += 1
    return {"noise_excerpts": excerpts, "false_alarms": len(alarms), "false_alarm_files": alarms,
            "speech_detected": {k: f"{a}/{n}" for k, (a, n) in heard.items()}}


if __name__ == "__main__":
    print(json.dumps(main(*sys.argv[1:]), indent=2))
