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
from siftom.inference.listen import ENGINES, ONLINE, Heard, hear
from siftom.inference.model import ModelConfig, Observation, OnlineInference, Posterior, SIFToM
from siftom.inputs import SceneInput
from siftom.likelihood.base import Hypothesis, Instruction, InstructionLikelihood
from siftom.settings import Settings
from siftom.speech.asr import DEFAULT_NBEST
from siftom.world.commands import MAX_COUNT

LikelihoodArg = str | InstructionLikelihood


def get_model(mode: str = "full", likelihood: LikelihoodArg = "phonetic", llm: LLMConfig | None = None,
              config: ModelConfig | None = None, options: dict[str, Any] | None = None) -> SIFToM:
    """A model for a mode ("full", "speech-only", "action-only") and an instruction likelihood.

    ``config`` gives the model's other options (its ``mode`` is replaced by ``mode``);
    ``options`` the named likelihood's constructor options (``Settings.likelihood_options``).

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
        cfg = dataclasses.replace(config or ModelConfig(), mode=mode)
        return SIFToM(cfg, likelihood if cfg.uses_speech else None)
    llm = (llm if llm is not None else LLMConfig.from_env()) if likelihood == "llm" else None
    opts = tuple(sorted((options or {}).items()))
    return _cached_model(dataclasses.replace(config or ModelConfig(), mode=mode), likelihood, llm, opts)


@lru_cache(maxsize=8)
def _cached_model(cfg: ModelConfig, likelihood: str, llm: LLMConfig | None,
                  options: tuple[tuple[str, Any], ...] = ()) -> SIFToM:
    from siftom.likelihood.registry import get_likelihood

    lk: InstructionLikelihood | None = None
    if cfg.uses_speech:
        kwargs = dict(options)
        lk = get_likelihood(likelihood, backend=llm, **kwargs) if llm is not None else get_likelihood(likelihood, **kwargs)
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


def _likelihood_key(likelihood: LikelihoodArg) -> Any:
    return likelihood if isinstance(likelihood, str) else ("object", id(likelihood), likelihood)


def _run(sc: SceneInput, heard: Instruction | np.ndarray | None, likelihood: LikelihoodArg | None, st: Settings,
         mode: str | None = None, engine: str | None = None, nbest: int | None = None,
         top: int | None = None) -> Heard:
    """The one path from a resolved scene and what was heard to the posterior (audio: VAD + ASR first).

    ``likelihood`` None or ``"auto"``: the best one the input allows (``resolve_likelihood``);
    ``evidence['likelihood']`` and ``evidence['likelihood_reason']`` say which ran and why.
    """
    from siftom.inference.listen import with_likelihood
    from siftom.likelihood.registry import resolve_likelihood

    t0 = time.perf_counter()
    opts = st.infer
    has_audio = isinstance(heard, np.ndarray) or (isinstance(heard, Instruction) and heard.has_audio)
    if likelihood is None or isinstance(likelihood, str):
        likelihood, why = resolve_likelihood(likelihood, has_audio=has_audio)
    else:
        why = "given as an object"
    mode = mode or st.model.mode
    tr = vad = None
    timings: dict[str, float] = {}
    instruction: Instruction | None
    if isinstance(heard, np.ndarray):
        asr = engine_for(sc.world, sc.verb, engine or opts.engine)
        instruction, tr, vad, timings = hear(heard, asr, nbest or opts.nbest)
        speech = instruction is not None
    else:
        instruction, speech = heard, heard is not None
    t1 = time.perf_counter()
    use_mode, use_lik = (("action-only", "phonetic") if instruction is None and mode != "speech-only"
                         else (mode, likelihood))
    post = _online(sc, use_mode, use_lik, st).posterior(instruction, top=top or opts.top)
    if instruction is not None:
        post = with_likelihood(post, use_lik if isinstance(use_lik, str) else type(use_lik).__name__, why)
    said = True
    if vad is not None and instruction is not None and post.evidence.get("no_instruction"):
        # words, but none near a command of the scene: the actions alone, and no command issued
        said = False
        alone = _online(sc, "action-only", "phonetic", st).posterior(None, top=top or opts.top)
        post = dataclasses.replace(alone, transcript=post.transcript, evidence=post.evidence)
    timings = {**timings, "infer": time.perf_counter() - t1}
    return Heard(post, speech, tr, vad, time.perf_counter() - t0, timings, instruction=said)


def _online(sc: SceneInput, mode: str, likelihood: LikelihoodArg, st: Settings) -> OnlineInference:
    """The cached online inference of ``sc`` (its actions observed) for a mode and likelihood."""
    llm = st.llm if likelihood == "llm" else None
    lk_opts = st.likelihood_options(likelihood) if isinstance(likelihood, str) else None
    model = get_model(mode, likelihood, llm, st.model, lk_opts)

    def make() -> OnlineInference:
        on = model.online(sc.world, sc.start, sc.goals, sc.verb)
        for a in sc.actions:
            on.observe(a)
        return on

    key = (sc.key, model.config, _likelihood_key(likelihood), llm, tuple(sorted((lk_opts or {}).items())))
    online: OnlineInference = ONLINE.get(key, make)
    return online


def _decided(post: Posterior, sc: SceneInput, decide: Any, st: Settings) -> Posterior:
    from siftom.assist.decide import Situation, get_rule

    if post.joint is None or post.joint.state is None:
        return post
    rule = get_rule(decide, **st.rule_options(decide)) if isinstance(decide, str) else decide
    return dataclasses.replace(post, decision=rule(post, Situation(sc.world, post.joint.state, sc.target)))


def infer(
    scene: Any,
    actions: Any = None,
    heard: Any = None,
    *,
    likelihood: LikelihoodArg | None = None,
    decide: Any = None,
    settings: Settings | None = None,
) -> Posterior:
    """The robot command a person meant, from what they did and said.

    Args:
        scene: a registered scenario id (``kitchen-cereal-v0``), a path to a siftom world JSON
            or a VirtualHome scene graph, or a loaded scene (``siftom.world.io.load_scene``).
        actions: the person's actions: siftom action strings (``grab(human, milk, fridge)``),
            VirtualHome script lines (``[Grab] <milk> (195)``), or a path to a file of them.
            None: the scenario's own actions (none for a world file).
        heard: a transcript, an N-best list (texts best first, or (text, log score) pairs), a
            path to an audio file, or 16 kHz mono samples. None: the actions alone.
        likelihood: a registered likelihood name or an object with ``log_prob`` (default:
            ``settings.infer.likelihood``).
        decide: a decision rule name (``map``, ``expected-benefit``, ``ask-or-act``) or rule;
            the posterior's ``decision`` holds what it decided.
        settings: every other option (default: :meth:`Settings.load`: ``SIFTOM_*`` and
            ``SIFTOM_CONFIG``).

    Returns:
        Posterior: ``command`` (a RobotCommand), ``commands``, ``goals``, ``evidence`` and,
        with ``decide``, ``decision``. From audio without speech it is the actions-alone
        posterior and ``evidence["speech_heard"]`` is False.

    Example::

        >>> p = siftom.infer("docs/examples/salad/world.json", "docs/examples/salad/actions.txt",
        ...                  "can you get me the potato")
        >>> str(p.command)
        'fetch(tomato)'
    """
    from siftom.inputs import as_heard, resolve_scene

    st = settings if settings is not None else Settings.load()
    sc = resolve_scene(scene, actions)
    got = as_heard(heard)
    if got is None and st.model.mode == "speech-only":
        raise ObservationError("speech-only inference needs heard= (a transcript, an N-best list or audio)")
    h = _run(sc, got, likelihood if likelihood is not None else st.infer.likelihood, st)
    post = h.posterior
    if h.vad is not None:  # from audio: say whether speech, and an instruction, was heard
        post = dataclasses.replace(post, evidence={**post.evidence, "speech_heard": h.speech,
                                                    "instruction_heard": h.speech and h.instruction,
                                                    **({"message": h.message} if h.message else {})})
    rule = decide if decide is not None else (st.infer.decide or None)
    return _decided(post, sc, rule, st) if rule is not None else post


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
    likelihood: LikelihoodArg | None = None,
    engine: str = "pocketsphinx",
    nbest: int = DEFAULT_NBEST,
    top: int = 10,
    decide: Any = None,
    settings: Settings | None = None,
) -> Heard:
    """Infer the robot command from a recording of the instruction and the human's actions.

    The same path as :func:`infer` with audio, returning the recogniser's output and timings too.

    Args:
        audio: a file path (WAV, FLAC, ...) or 16 kHz mono samples.
        scenario: a registered scenario id, a world file path or a Scenario (its actions are
            used unless ``actions`` is given).
        world: instead of ``scenario``: a loaded scene (``siftom.world.io.load_scene``) or a
            World with ``start`` and ``goals``.
        actions: the human's actions (strings like ``grab(human, milk, fridge)`` or Actions).
        mode: ``full``, ``speech-only`` or ``action-only``.
        likelihood: ``phonetic`` (N-best), ``acoustic`` (the audio itself) or ``llm``; None
            (default): ``acoustic`` when the whisper extra is installed, else ``phonetic``
            (``evidence['likelihood']`` and ``evidence['likelihood_reason']`` say which ran and why).
        engine: the ASR engine.
        decide: a decision rule name or rule (as in :func:`infer`).

    Returns:
        Heard: the posterior, whether speech was heard, the transcript and timings. Without
        speech the posterior is the actions-alone one and ``message`` is "no speech heard".
    """
    from siftom.speech.audio import as_audio

    t0 = time.perf_counter()
    st = settings if settings is not None else Settings.load()
    sc = _scene_of(scenario, world, actions, start, goals, verb)
    x = as_audio(audio)
    t_load = time.perf_counter() - t0
    h = _run(sc, x, likelihood, st, mode=mode, engine=engine, nbest=nbest, top=top)
    if decide is not None:
        h = dataclasses.replace(h, posterior=_decided(h.posterior, sc, decide, st))
    return dataclasses.replace(h, seconds=time.perf_counter() - t0, timings={"load": t_load, **h.timings})
