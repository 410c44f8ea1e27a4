"""siftom: follow noisy spoken instructions pragmatically (SIFToM).

Bayesian inverse planning over a symbolic scene combined with instruction likelihoods
computed from what was heard (transcripts, N-best lists or the audio itself).

What a person did and said, to the robot command they meant, in one call::

    import siftom

    a = siftom.infer("docs/examples/salad/world.json", "docs/examples/salad/actions.txt",
                     "can you get me the potato")
    a.action, a.command  # "act", RobotCommand fetch(tomato): what the robot does
    a.top_command        # the most probable command, whatever the robot does

``heard`` may also be an N-best list, a path to a recording or samples; ``siftom.listen``
returns the recogniser's output and timings as well. Both are one-shot uses of
``siftom.Observer``, the object every door (CLI, HTTP, sessions, streams, ROS) goes through. The names below are loaded on first use,
so ``import siftom`` stays light.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.2.0"

# public name -> the module that defines it (imported on first use)
_PUBLIC: dict[str, str] = {
    "infer": "siftom.api",
    "listen": "siftom.api",
    "infer_scenario": "siftom.api",
    "infer_actions": "siftom.api",
    "make_instruction": "siftom.api",
    "transcribe_for": "siftom.api",
    "Answer": "siftom.answer",
    "Observer": "siftom.observer",
    "Posterior": "siftom.inference.model",
    "JointHypothesis": "siftom.inference.model",
    "ModelConfig": "siftom.inference.model",
    "RobotCommand": "siftom.world.commands",
    "Instruction": "siftom.observation",
    "Hypothesis": "siftom.observation",
    "InstructionLikelihood": "siftom.likelihood.base",
    "Settings": "siftom.settings",
    "InferOptions": "siftom.options",
    "Registry": "siftom.registry",
    "SiftomError": "siftom.errors",
    "ObservationError": "siftom.errors",
    "AudioError": "siftom.errors",
    "CommandParseError": "siftom.errors",
    "UnknownNameError": "siftom.errors",
    "BackendUnavailableError": "siftom.errors",
    "OptionsError": "siftom.errors",
    "SettingsError": "siftom.errors",
}
__all__ = [
    "__version__",
    "Answer",
    "AudioError",
    "BackendUnavailableError",
    "CommandParseError",
    "Hypothesis",
    "InferOptions",
    "Instruction",
    "InstructionLikelihood",
    "JointHypothesis",
    "ModelConfig",
    "ObservationError",
    "Observer",
    "OptionsError",
    "Posterior",
    "Registry",
    "RobotCommand",
    "Settings",
    "SettingsError",
    "SiftomError",
    "UnknownNameError",
    "infer",
    "infer_actions",
    "infer_scenario",
    "listen",
    "make_instruction",
    "transcribe_for",
]

if TYPE_CHECKING:  # what type checkers see; at run time the names load on first use
    from siftom.answer import Answer
    from siftom.api import (
        infer,
        infer_actions,
        infer_scenario,
        listen,
        make_instruction,
        transcribe_for,
    )
    from siftom.errors import (
        AudioError,
        BackendUnavailableError,
        CommandParseError,
        ObservationError,
        OptionsError,
        SettingsError,
        SiftomError,
        UnknownNameError,
    )
    from siftom.inference.model import JointHypothesis, ModelConfig, Posterior
    from siftom.likelihood.base import InstructionLikelihood
    from siftom.observation import Hypothesis, Instruction
    from siftom.observer import Observer
    from siftom.options import InferOptions
    from siftom.registry import Registry
    from siftom.settings import Settings
    from siftom.world.commands import RobotCommand


def __getattr__(name: str) -> Any:
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'siftom' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    """The public names and the module's dunders (not its own imports)."""
    return sorted({*_PUBLIC, *(n for n in globals() if n.startswith("__"))})
