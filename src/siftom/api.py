"""One entry point for callers (CLI, HTTP service, evaluator): run SIFToM on a request.

A request names a registered scenario or carries its own world (``siftom.world.io`` JSON),
the human's actions in ``Predicate(agent, object, location)`` form, and what was heard.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from siftom.backends.config import LLMConfig
from siftom.errors import ObservationError
from siftom.inference.listen import ENGINES, LOCK, NO_SPEECH, ONLINE, Heard, hear, resolve_scene  # noqa: F401
from siftom.inference.model import ModelConfig, Observation, OnlineInference, Posterior, SIFToM
from siftom.likelihood.base import Hypothesis, Instruction, InstructionLikelihood
from siftom.speech.asr import DEFAULT_NBEST
from siftom.world.commands import MAX_COUNT

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
    transcript: Any = None,
    nbest: Any = None,
    audio: str | Path | None = None,
) -> Instruction | None:
    """Build an Instruction from whichever of transcript / N-best / audio is given.

    ``nbest`` may be a list of (text, score) pairs, ``{text, score}`` dicts or Hypothesis
    objects, or anything a transcription returns (a ``Transcript``, or its ``to_json()``);
    ``transcript`` may be a string or a ``Transcript``.
    """
    if hasattr(transcript, "nbest") and hasattr(transcript, "text"):  # a Transcript given as the transcript
        transcript, nbest = None, transcript if nbest is None else nbest
    if hasattr(nbest, "nbest") and hasattr(nbest, "text"):  # a Transcript
        words = tuple((w.text, w.start, w.end) for w in getattr(nbest, "words", ()))
        hyps_t = tuple(h for h in nbest.nbest if h.text) or ((Hypothesis(nbest.text, 0.0),) if nbest.text else ())
        if not hyps_t and audio is None:
            raise ObservationError("nothing was recognised in the recording (the transcript is empty); "
                                   "record the instruction again or infer from the actions alone")
        return Instruction(nbest=hyps_t, audio=Path(audio) if audio is not None else None, words=words)
    if isinstance(nbest, dict) and "nbest" in nbest:  # Transcript.to_json()
        nbest = nbest["nbest"] or ([{"text": nbest["text"], "score": 0.0}] if nbest.get("text") else [])
    hyps: list[Hypothesis] = []
    if nbest:
        for k, h in enumerate(nbest):
            if isinstance(h, Hypothesis):
                hyps.append(h)
            elif isinstance(h, dict):
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


def vocabulary_for(world: Any, verb: str, max_count: int = MAX_COUNT) -> list[str]:
    """Every phrasing of every command this world affords: the biased ASR vocabulary."""
    from siftom.likelihood.phrasing import command_vocabulary

    return command_vocabulary(world.classes, verb, max_count)


def transcribe_for(audio: str | Path, world: Any = None, verb: str = "fetch", engine: str = "pocketsphinx",
                   nbest: int = DEFAULT_NBEST) -> Any:
    """Transcribe an instruction; pocketsphinx is biased to the world's command phrasings."""
    from siftom.speech.asr.base import get_engine

    options: dict[str, Any] = {}
    if engine == "pocketsphinx" and world is not None:
        options["vocabulary"] = vocabulary_for(world, verb)
    return get_engine(engine, **options).transcribe(audio, nbest=nbest)


# ----- audio in, posterior out (siftom.inference.listen has the parts) ---------------------------

def engine_for(world: Any, verb: str, engine: str = "pocketsphinx") -> Any:
    """A cached recogniser; pocketsphinx is biased to the world's command phrasings."""
    from siftom.speech.asr.base import get_engine

    if engine != "pocketsphinx":
        return ENGINES.get((engine,), lambda: get_engine(engine))
    vocab = tuple(sorted(vocabulary_for(world, verb)))
    return ENGINES.get((engine, hash(vocab)), lambda: get_engine("pocketsphinx", vocabulary=list(vocab)))


def listen(
    audio: str | Path | np.ndarray,
    scenario: Any = None,
    world: Any = None,
    actions: Sequence[Any] | None = None,
    *,
    start: Any = None,
    goals: Sequence[Any] | None = None,
    verb: str | None = None,
    mode: str = "full",
    likelihood: str | None = None,
    engine: str = "pocketsphinx",
    nbest: int = DEFAULT_NBEST,
    top: int = 10,
) -> Heard:
    """Infer the robot command from a recording of the instruction and the human's actions.

    Args:
        audio: a file path (WAV, FLAC, ...) or 16 kHz mono samples.
        scenario: a registered scenario id or a Scenario (its actions are used unless
            ``actions`` is given).
        world: instead of ``scenario``: a loaded scene (``siftom.world.io.load_scene``) or a
            World with ``start`` and ``goals``.
        actions: the human's actions (strings like ``grab(human, milk, fridge)`` or Actions).
        mode: ``full``, ``speech-only`` or ``action-only``.
        likelihood: ``phonetic`` (N-best), ``acoustic`` (the audio itself) or ``llm``; None
            (default): ``acoustic`` when the whisper extra is installed, else ``phonetic``
            (``evidence['likelihood']`` and ``evidence['likelihood_reason']`` say which ran and why).
        engine: the ASR engine.

    Returns:
        Heard: the posterior, whether speech was heard, the transcript and timings. Without
        speech the posterior is the actions-alone one and ``message`` is "no speech heard".
    """
    from siftom.inference.listen import with_likelihood
    from siftom.likelihood.registry import resolve_likelihood
    from siftom.speech.audio import as_audio

    likelihood, why = resolve_likelihood(likelihood, has_audio=True)
    t0 = time.perf_counter()
    sc = resolve_scene(scenario, world, actions, start, goals, verb)
    x = as_audio(audio)
    t_load = time.perf_counter() - t0
    with LOCK:
        asr = engine_for(sc.world, sc.verb, engine)
        instruction, tr, vad, timings = hear(x, asr, nbest)
        t1 = time.perf_counter()
        if instruction is None:
            use_mode, use_lik = "action-only", "phonetic"
        else:
            use_mode, use_lik = mode, likelihood

        def make() -> OnlineInference:
            on = get_model(use_mode, use_lik).online(sc.world, sc.start, sc.goals, sc.verb)
            for a in sc.actions:
                on.observe(a)
            return on

        online = ONLINE.get((sc.key, use_mode, use_lik), make)
        post = online.posterior(instruction, top=top)
        if instruction is not None:
            post = with_likelihood(post, use_lik, why)
        said = not post.evidence.get("no_instruction")
        if not said:  # words, but none near a command: the actions alone, and no command issued
            use_mode, use_lik = "action-only", "phonetic"
            alone = ONLINE.get((sc.key, use_mode, use_lik), make).posterior(None, top=top)
            post = dataclasses.replace(alone, transcript=post.transcript, evidence=post.evidence)
    timings = {"load": t_load, **timings, "infer": time.perf_counter() - t1}
    return Heard(post, instruction is not None, tr, vad, time.perf_counter() - t0, timings, instruction=said)
