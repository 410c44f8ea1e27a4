"""One entry point for callers (CLI, HTTP service, evaluator): run SIFToM on a request.

A request names a registered scenario or carries its own world (``siftom.world.io`` JSON),
the human's actions in ``Predicate(agent, object, location)`` form, and what was heard.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.answer import Answer
from siftom.backends.config import LLMConfig
from siftom.errors import ObservationError
from siftom.inference.model import Posterior
from siftom.inputs import SceneInput
from siftom.likelihood.base import Hypothesis, Instruction, InstructionLikelihood
from siftom.settings import Settings
from siftom.speech.asr import DEFAULT_NBEST
from siftom.world.commands import MAX_COUNT

LikelihoodArg = str | InstructionLikelihood


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
    from siftom.inputs import resolve_scene
    from siftom.observer import observer_for
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    if n_actions is not None and not 0 <= n_actions <= len(sc.actions):
        raise ObservationError(f"n_actions must be between 0 and {len(sc.actions)} for {scenario_id}")
    scene = resolve_scene(scenario_id, list(sc.actions[:n_actions]) if n_actions is not None else None)
    obs = observer_for(_with_llm(None, llm))
    return obs.answer(obs.online(scene, mode), instruction, likelihood=likelihood, decide="map").posterior


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
    from siftom.inputs import resolve_scene
    from siftom.observer import observer_for

    scene = resolve_scene(scenario_id, list(actions))  # siftom's or VirtualHome's script format
    obs = observer_for(_with_llm(None, llm))
    return obs.answer(obs.online(scene, mode), instruction, likelihood=likelihood, decide="map").posterior


def _with_llm(settings: Settings | None, llm: LLMConfig | None) -> Settings:
    """``settings`` (default: :meth:`Settings.load`) with ``llm`` as the language model."""
    st = settings if settings is not None else Settings.load()
    if llm is None:
        return st
    flags = {f"llm.{k}": v for k, v in dataclasses.asdict(llm).items() if v is not None}
    return Settings.load(flags=flags) if settings is None else st


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


# ----- the one-shot doors: an observer per settings (siftom.observer) -----------------------

def engine_for(world: Any, verb: str, engine: str = "pocketsphinx") -> Any:
    """The shared observer's recogniser for a scene (pocketsphinx biased to its command phrasings)."""
    from siftom.observer import observer_for

    return observer_for().recogniser(world, verb, engine)


def _scene_of(scenario: Any, world: Any, actions: Sequence[Any] | None, start: Any, goals: Any,
              verb: str | None) -> SceneInput:
    """listen()'s scene arguments as a SceneInput."""
    from siftom.inputs import make_scene, resolve_scene

    if (scenario is None) == (world is None):
        raise ObservationError("give exactly one of scenario= (an id or Scenario) or world= (a scene or World)")
    src = scenario if scenario is not None else world
    if hasattr(src, "world") or isinstance(src, (str, Path)):
        sc = resolve_scene(src, actions)
        return dataclasses.replace(sc, verb=verb) if verb else sc
    if start is None or goals is None:
        raise ObservationError("with world=World give start= (its State) and goals= (the goal space)")
    return make_scene(src, start, goals, actions or (), verb or "deliver")


def infer(
    scene: Any,
    actions: Any = None,
    heard: Any = None,
    *,
    likelihood: LikelihoodArg | None = None,
    decide: Any = None,
    settings: Settings | None = None,
    pending: Any = None,
) -> Answer:
    """What the robot does about what a person did and said: the decision beside the posterior.

    A one-shot use of :class:`siftom.Observer` (``Observer(settings).infer(...)``); calls with the
    same settings share one observer, so its models and per-scene caches are built once.

    Args:
        scene: a registered scenario id (``kitchen-cereal-v0``), a path to a siftom world JSON
            or a VirtualHome scene graph, or a loaded scene (``siftom.world.io.load_scene``).
        actions: the person's actions: siftom action strings (``grab(human, milk, fridge)``),
            VirtualHome script lines (``[Grab] <milk> (195)``), or a path to a file of them.
            None: the scenario's own actions (none for a world file).
        heard: a transcript, an N-best list (texts best first, or (text, log score) pairs), a
            path to an audio file, or 16 kHz mono samples. None: nothing was said.
        likelihood: a registered likelihood name or an object with ``log_prob`` (default:
            the setting ``infer.likelihood``, ``auto``: acoustic for audio with the whisper
            extra, else phonetic).
        decide: a decision rule name (``teammate``, ``expected-benefit``, ``ask-or-act``, ``map``)
            or rule (default: the setting ``infer.decide``, ``teammate``).
        settings: every other option (default: :meth:`Settings.load`: ``SIFTOM_*`` and
            ``SIFTOM_CONFIG``).
        pending: the question a previous answer asked (its ``answer.pending``): these words
            are weighed as the reply to it, with the request that led to it (docs/decisions.md).

    Returns:
        Answer: ``action`` (act, ask or none), ``command`` (what the robot carries out, or None),
        ``top_command`` (the most probable command), ``decision`` (the rule, its reason, the
        question), ``commands``, ``goals`` and ``evidence``. Without speech, or with words near
        no command of the scene, the action is ``none``.

    Example::

        >>> a = siftom.infer("docs/examples/salad/world.json", "docs/examples/salad/actions.txt",
        ...                  "can you get me the potato")
        >>> str(a.top_command)
        'fetch(tomato)'
    """
    from siftom.observer import observer_for

    return observer_for(settings).infer(scene, actions, heard, likelihood=likelihood, decide=decide, pending=pending)


def listen(
    audio: str | Path | np.ndarray,
    scenario: Any = None,
    world: Any = None,
    actions: Sequence[Any] | None = None,
    *,
    start: Any = None,
    goals: Sequence[Any] | None = None,
    verb: str | None = None,
    mode: str | None = None,
    likelihood: LikelihoodArg | None = None,
    engine: str | None = None,
    nbest: int | None = None,
    top: int | None = None,
    decide: Any = None,
    settings: Settings | None = None,
) -> Answer:
    """What the robot does about a recording of the instruction and the person's actions.

    The same path as :func:`infer` with audio (``Observer.listen``), with the recogniser's output
    (``asr``), the detector's (``vad``) and the seconds per stage (``timings``) kept.

    Args:
        audio: a file path (WAV, FLAC, ...) or 16 kHz mono samples.
        scenario: a registered scenario id, a world file path or a Scenario (its actions are
            used unless ``actions`` is given).
        world: instead of ``scenario``: a loaded scene (``siftom.world.io.load_scene``) or a
            World with ``start`` and ``goals``.
        actions: the person's actions (strings like ``grab(human, milk, fridge)`` or Actions).
        mode, likelihood, engine, nbest, top, decide: left out, the settings (``model.mode``,
            ``infer.likelihood``, ``infer.engine``, ``infer.nbest``, ``infer.top``, ``infer.decide``).

    Returns:
        Answer: as :func:`infer`. Without speech the posterior is the actions-alone one, the
        action is ``none`` and ``message`` is "no speech heard".
    """
    from siftom.observer import observer_for

    sc = _scene_of(scenario, world, actions, start, goals, verb)
    return observer_for(settings).listen(audio, sc, likelihood=likelihood, decide=decide, mode=mode, top=top,
                                         engine=engine, nbest=nbest)
