"""The per-stimulus start shared by the feature-dump research scripts (acoustic_features, whisper_features).

``done_ids(path)``: the stimulus ids an output JSONL already holds (the scripts resume).
``base_record(ds, s, asr, model)``: hear the clip as the evaluator's acoustic path does
(``siftom.bench.acoustic_models.heard``, 5-best), list the scenario's commands and their action
context, and start the record every dump shares (id, SNR, voice, style, gold, commands, which
are correct, the context).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np


def done_ids(path: Path) -> set[str]:
    """Ids already written to ``path`` (empty when it does not exist)."""
    if not path.exists():
        return set()
    return {json.loads(line)["id"] for line in path.read_text().splitlines() if line.strip()}


def base_record(ds: Any, s: Any, asr: Any, model: Any) -> tuple[Any, Any, Any, list, dict]:
    """(scenario, instruction or None without speech, VAD result, commands, record) of stimulus ``s``."""
    from siftom.bench.acoustic_models import heard
    from siftom.bench.calibrate import _commands, _context
    from siftom.bench.stimuli import scenario_for
    from siftom.bench.trials import is_correct

    sc = scenario_for(s)
    instruction, vad = heard(ds.root / s.audio, asr, 5)
    cmds = _commands(model, sc)
    ctx = np.asarray(_context(model, sc), dtype=float)
    rec: dict = {"id": s.id, "snr": "clean" if s.snr_db is None else f"{s.snr_db:g} dB",
                 "voice": s.voice, "style": s.style, "gold": s.gold_command,
                 "cmds": [str(c) for c in cmds],
                 "correct": [is_correct(str(c), s.gold_command, sc.verb) for c in cmds],
                 "ctx": np.round(ctx, 4).tolist()}
    return sc, instruction, vad, cmds, rec
