"""CPU-time real-time factor of the scene engines (wall time is inflated on a shared machine).

Run: .venv/bin/python benchmarks/scene_asr_rtf.py
The bench-asr sentences (grammar, out-of-scene and free) x 2 voices x clean and 10 dB babble.
"""
import time

import numpy as np

from siftom.bench.speech import ASR_SENTENCES, FREE_SENTENCES, _vocabulary
from siftom.speech.asr.base import get_engine
from siftom.speech.noise import get_noise, mix_at_snr
from siftom.speech.tts import synthesize

sents = [s for s, _ in ASR_SENTENCES] + list(FREE_SENTENCES)
clips = []
for v in ("flite-slt", "espeak-en-us+klatt"):
    for i, s in enumerate(sents):
        x = synthesize(s, v)
        clips += [x, mix_at_snr(x, get_noise("babble"), 10, np.random.default_rng(i))]
for name, kw in (("pocketsphinx-vocab", {}), ("pocketsphinx-open", {"background_words": 2000})):
    e = get_engine("pocketsphinx", vocabulary=_vocabulary(), **kw)
    e.transcribe(clips[0])
    cpu = wall = audio = 0.0
    for x in clips:
        c0, w0 = time.process_time(), time.perf_counter()
        e.transcribe(x, nbest=5)
        cpu += time.process_time() - c0
        wall += time.perf_counter() - w0
        audio += len(x) / 16000
    print(f"{name}: RTF cpu {cpu/audio:.3f} wall {wall/audio:.3f} over {len(clips)} clips, {audio:.0f} s audio")
