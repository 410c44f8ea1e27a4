"""The VAD's speech-to-background estimate (dB) of every stimulus of a dataset, as JSON {id: snr_db}.

    PYTHONPATH=src python benchmarks/snr_estimates.py DATASET OUT.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from siftom.bench.stimuli import load_dataset
from siftom.speech.audio import load_audio
from siftom.speech.vad import detect_speech

if __name__ == "__main__":
    ds = load_dataset(sys.argv[1], check_audio=False)
    out = {}
    for s in ds.stimuli:
        r = detect_speech(load_audio(Path(sys.argv[1]) / s.audio))
        out[s.id] = r.snr_db
    Path(sys.argv[2]).write_text(json.dumps(out))
    print(len(out))
