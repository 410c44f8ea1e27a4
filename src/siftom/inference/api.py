"""One entry point for callers (CLI, HTTP service, evaluator): run SIFToM on a request.

A request names a registered scenario or carries its own world (``siftom.world.io`` JSON),
the human's actions in ``Predicate(agent, object, location)`` form, and what was heard.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from siftom.errors import ObservationError
from siftom.inference.model import ModelConfig, Observation, Posterior, SIFToM
from siftom.likelihood.base import Hypothesis, Instruction, InstructionLikelihood


@lru_cache(maxsize=8)
def get_model(mode: str = "full", likelihood: str = "phonetic") -> SIFToM:
    """A cached model for a mode ("full", "speech-only", "action-only") and likelihood name."""
    from siftom.likelihood.registry import get_likelihood

    cfg = ModelConfig(mode=mode)
    lk: InstructionLikelihood | None = get_likelihood(likelihood) if cfg.uses_speech else None
    return SIFToM(cfg, lk)


def make_instruction(
    transcript: str | None = None,
    nbest: Sequence[tuple[str, float] | dict[str, Any]] | None = None,
    audio: str | Path | None = None,
) -> Instruction | None:
    """Build an Instruction from whichever of transcript / N-best / audio is given."""
    hyps: list[Hypothesis] = []
    if nbest:
        for k, h in enumerate(nbest):
            if isinstance(h, dict):
                if "text" not in h:
                    raise ObservationError(f"nbest[{k}] needs a 'text' field, e.g. {{'text': 'pass me the cereal', 'score': -3.2}}")
                hyps.append(Hypothesis(str(h["text"]), float(h.get("score", 0.0))))
            else:
                hyps.append(Hypothesis(str(h[0]), float(h[1])))
    elif transcript is not None:
        if not str(transcript).strip():
            raise ObservationError("the transcript is empty; give the words that were heard")
        hyps.append(Hypothesis(str(transcript).strip(), 0.0))
    if not hyps and audio is None:
        return None
    return Instruction(nbest=tuple(hyps), audio=Path(audio) if audio is not None else None)


def infer_scenario(
    scenario_id: str,
    instruction: Instruction | None,
    mode: str = "full",
    likelihood: str = "phonetic",
    n_actions: int | None = None,
) -> Posterior:
    """Run inference on a registered scenario with its observed actions (or the first ``n_actions``)."""
    from siftom.world.domains.base import get_scenario

    sc = get_scenario(scenario_id)
    if n_actions is not None and not 0 <= n_actions <= len(sc.actions):
        raise ObservationError(f"n_actions must be between 0 and {len(sc.actions)} for {scenario_id}")
    obs = Observation.from_scenario(sc, instruction, n_actions)
    return get_model(mode, likelihood).infer(obs)


def infer_actions(
    scenario_id: str,
    actions: Sequence[str],
    instruction: Instruction | None,
    mode: str = "full",
    likelihood: str = "phonetic",
) -> Posterior:
    """Inference on a registered scenario's start state with the caller's own action strings
    (siftom's ``walk(human, fridge)`` or VirtualHome's ``[Walk] <fridge> (1)``, see world/vhscript.py)."""
    from siftom.world.domains.base import get_scenario
    from siftom.world.vhscript import parse_actions

    sc = get_scenario(scenario_id)
    acts, _ = parse_actions(sc.world, sc.start, actions)  # siftom's or VirtualHome's script format
    obs = Observation(sc.world, sc.start, tuple(acts), sc.goals, sc.verb, instruction)
    return get_model(mode, likelihood).infer(obs)


def vocabulary_for(world: Any, verb: str, max_count: int = 4) -> list[str]:
    """Every phrasing of every command this world affords: the biased ASR vocabulary."""
    from siftom.likelihood.phrasing import command_vocabulary

    return command_vocabulary(world.classes, verb, max_count)


def transcribe_for(audio: str | Path, world: Any = None, verb: str = "fetch", engine: str = "pocketsphinx",
                   nbest: int = 10) -> Any:
    """Transcribe an instruction; pocketsphinx is biased to the world's command phrasings."""
    from siftom.speech.asr.base import get_engine

    options: dict[str, Any] = {}
    if engine == "pocketsphinx" and world is not None:
        options["vocabulary"] = vocabulary_for(world, verb)
    return get_engine(engine, **options).transcribe(audio, nbest=nbest)
