"""The evaluator's acoustic models: the path of ``siftom.api.listen`` on each stimulus.

* ``siftom-acoustic``: voice-activity detection, recognition of the speech (N-best and word
  times), then the full model with the acoustic (key-phrase alignment) likelihood;
* ``speech-only-acoustic``: the same likelihood with a uniform prior and no actions.

A stimulus in which no speech is detected gets the posterior from the actions alone (full
model) or no command (speech-only), as ``siftom.api.listen`` does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

_HEARD: dict[str, tuple[Any, Any]] = {}


def heard(audio: Path, engine: Any, nbest: int) -> tuple[Any, Any]:
    """(instruction or None, VAD result) for one stimulus, shared by both acoustic models."""
    from siftom.inference.listen import hear
    from siftom.speech.audio import load_audio

    key = str(audio)
    if key not in _HEARD:
        _HEARD.clear()  # one stimulus at a time
        instruction, _, vad, _ = hear(load_audio(audio), engine, nbest)
        _HEARD[key] = (instruction, vad)
    return _HEARD[key]


def acoustic_choice(model: str, scenario: Any, audio: Path, engine: Any, nbest: int) -> tuple[str, float]:
    """The chosen command and its posterior probability under an acoustic model."""
    from siftom.api import get_model
    from siftom.inference.model import Observation

    instruction, _ = heard(audio, engine, nbest)
    mode = "full" if model == "siftom-acoustic" else "speech-only"
    if instruction is None:
        if mode == "speech-only":
            return "none", 1.0
        post = get_model("action-only", "phonetic").infer(Observation.from_scenario(scenario, None))
    else:
        post = get_model(mode, "acoustic").infer(Observation.from_scenario(scenario, instruction))
    return post.command, float(post.commands[0][1])
