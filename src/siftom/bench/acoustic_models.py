"""The evaluator's acoustic models: the instruction likelihood of ``siftom.api.listen`` on each stimulus.

* ``siftom-acoustic``: the full model with the acoustic likelihood (key-phrase alignment
  combined with the N-best, docs/likelihoods.md);
* ``speech-only-acoustic``: the same likelihood with a uniform prior and no actions.

Both hear the stimulus as the N-best models do: the whole clip goes to the same recogniser
(N-best and word times), so a row differs from ``siftom`` / ``speech-only`` only in the
instruction likelihood. The voice-activity detector runs for its SNR estimate; it does not gate
or cut the clip here (the benchmark's clips all hold speech, and the N-best models are not
gated either). A clip the recogniser returns no words for gets the posterior from the actions
alone (full model) or no command (speech-only).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

_HEARD: dict[str, tuple[Any, Any]] = {}


def heard(audio: Path, engine: Any, nbest: int) -> tuple[Any, Any]:
    """(instruction or None, VAD result) for one stimulus, shared by both acoustic models."""
    import dataclasses

    from siftom.speech.audio import load_audio
    from siftom.speech.vad import detect_speech

    key = str(audio)
    if key not in _HEARD:
        _HEARD.clear()  # one stimulus at a time
        x = load_audio(audio)
        vad = detect_speech(x)
        tr = engine.transcribe(x, nbest=nbest)
        instruction = (dataclasses.replace(tr.to_instruction(samples=x), snr_db=vad.snr_db)
                       if tr.text else None)
        _HEARD[key] = (instruction, vad)
    return _HEARD[key]


def acoustic_choice(model: str, scenario: Any, audio: Path, engine: Any, nbest: int) -> tuple[str, float]:
    """The chosen command and its posterior probability under an acoustic model (MAP), from the
    evaluator's observer."""
    from siftom.bench.models import eval_settings
    from siftom.observer import observer_for

    instruction, _ = heard(audio, engine, nbest)
    mode = "full" if model == "siftom-acoustic" else "speech-only"
    obs = observer_for(eval_settings(mode))
    if instruction is None:
        if mode == "speech-only":
            return "none", 1.0
        post = obs.infer(scenario, None, None, mode="action-only", decide="map", gate=False).posterior
    else:
        post = obs.infer(scenario, None, instruction, likelihood="acoustic", decide="map", gate=False).posterior
    return str(post.command), float(post.commands[0][1])
