"""One entry point for callers (CLI, HTTP service, evaluator): run SIFToM on a request.

A request names a registered scenario or carries its own world (``siftom.world.io`` JSON),
the human's actions in ``Predicate(agent, object, location)`` form, and what was heard.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from siftom.backends.config import LLMConfig
from siftom.errors import ObservationError
from siftom.inference.model import ModelConfig, Observation, Posterior, SIFToM
from siftom.likelihood.base import Hypothesis, Instruction, InstructionLikelihood

LikelihoodArg = str | InstructionLikelihood


def get_model(mode: str = "full", likelihood: LikelihoodArg = "phonetic", llm: LLMConfig | None = None) -> SIFToM:
    """A model for a mode ("full", "speech-only", "action-only") and an instruction likelihood.

    ``likelihood`` is a registered name (cached models) or a likelihood object (used as is).
    For "llm", ``llm`` says which language model (default: :meth:`LLMConfig.from_env`, read at
    each call, so the ``SIFTOM_LLM_*`` variables in force are the ones used).
    """
    if not isinstance(likelihood, str):
        if not isinstance(likelihood, InstructionLikelihood):
            raise ObservationError(
                f"likelihood must be a name ('phonetic', 'llm', 'acoustic') or an object with "
                f"log_prob(instruction, commands), got {type(likelihood).__name__}"
            )
        cfg = ModelConfig(mode=mode)
        return SIFToM(cfg, likelihood if cfg.uses_speech else None)
    llm = (llm if llm is not None else LLMConfig.from_env()) if likelihood == "llm" else None
    return _cached_model(mode, likelihood, llm)


@lru_cache(maxsize=8)
def _cached_model(mode: str, likelihood: str, llm: LLMConfig | None) -> SIFToM:
    from siftom.likelihood.registry import get_likelihood

    cfg = ModelConfig(mode=mode)
    lk: InstructionLikelihood | None = None
    if cfg.uses_speech:
        lk = get_likelihood(likelihood, backend=llm) if llm is not None else get_likelihood(likelihood)
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
    likelihood: LikelihoodArg = "phonetic",
    n_actions: int | None = None,
    llm: LLMConfig | None = None,
) -> Posterior:
    """Run inference on a registered scenario with its observed actions (or the first ``n_actions``).

    ``likelihood`` is a name or a likelihood object; ``llm`` configures the "llm" likelihood
    (default: the ``SIFTOM_LLM_*`` environment).
    """
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    if n_actions is not None and not 0 <= n_actions <= len(sc.actions):
        raise ObservationError(f"n_actions must be between 0 and {len(sc.actions)} for {scenario_id}")
    obs = Observation.from_scenario(sc, instruction, n_actions)
    return get_model(mode, likelihood, llm).infer(obs)


def infer_actions(
    scenario_id: str,
    actions: Sequence[str],
    instruction: Instruction | None,
    mode: str = "full",
    likelihood: LikelihoodArg = "phonetic",
    llm: LLMConfig | None = None,
) -> Posterior:
    """Inference on a registered scenario's start state with the caller's own action strings
    (siftom's ``walk(human, fridge)`` or VirtualHome's ``[Walk] <fridge> (1)``, see world/vhscript.py)."""
    from siftom.scenarios.base import get_scenario
    from siftom.world.vhscript import parse_actions

    sc = get_scenario(scenario_id)
    acts, _ = parse_actions(sc.world, sc.start, actions)  # siftom's or VirtualHome's script format
    obs = Observation(sc.world, sc.start, tuple(acts), sc.goals, sc.verb, instruction)
    return get_model(mode, likelihood, llm).infer(obs)


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
