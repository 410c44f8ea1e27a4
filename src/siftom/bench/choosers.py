"""How each kind of evaluator model chooses a command for a trial: one registered function per kind.

An evaluator model's ``kind`` names an entry of ``siftom.bench.models.EVAL_KINDS``, a
registry of the shape every plug-in uses: a function ``(trial: Trial) -> Choice``. SIFToM's
kinds go through the observer every door uses (``posterior``: ``Observer.infer`` with the MAP
rule; ``decision``: a decision rule answering through the observer, bench/decisions.py;
``acoustic``: the path ``siftom.listen`` takes); the baselines (``literal``, ``llm-baseline``)
are not SIFToM and choose on their own. A plug-in adds a kind without editing siftom::

    from siftom.bench.models import EVAL_KINDS
    EVAL_KINDS.register("mine", "mypkg.evalkind:choose", summary="...")
    # then register_eval_model("mine-model", kind="mine", ...)
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from siftom.bench.decisions import decision_heard, decision_posterior, run_decision_model
from siftom.bench.engines import engine as _engine
from siftom.bench.models import EVAL_KINDS, EvalModel, EvalOptions, eval_settings, siftom_likelihood
from siftom.people.stimuli import Stimulus
from siftom.world.commands import MAX_COUNT

# (scenario key, model, what it heard) -> (command, probability, unused)
Memo = dict[tuple[str, str, str], tuple[str, float, float]]


class Choice(NamedTuple):
    """What a model chose for a trial: the command (``none``: nothing), its probability, and the
    fields a decision model adds to its results entry (empty for the others)."""

    command: str
    prob: float
    extra: Mapping[str, Any] = {}


def instruction_from(nbest: Sequence[Mapping[str, Any]], engine: str | None = None) -> Any:
    """An ``Instruction`` from saved N-best entries (``{text, score}``); None when all are empty."""
    from siftom.observation import Hypothesis, Instruction
    from siftom.speech.asr.base import writes_scene_words

    hyps = tuple(Hypothesis(h["text"], float(h["score"])) for h in nbest if h["text"].strip())
    return Instruction(nbest=hyps, scene_words=writes_scene_words(engine)) if hyps else None


class TrialHeard:
    """What one stimulus's models hear: its transcript, N-best and clip, with the posterior and the
    decision models' input per likelihood computed once and shared by its models."""

    def __init__(self, options: EvalOptions, vocabulary: tuple[str, ...], audio: Path,
                 transcript: Mapping[str, Any]) -> None:
        self.options = options
        self.vocabulary = vocabulary
        self.tr = transcript
        self.instr = instruction_from(transcript["nbest"] or [{"text": transcript["text"], "score": 0.0}],
                                      transcript.get("engine"))
        self.audio = audio
        self._posts: dict[str, Any] = {}
        self._hears: dict[str, Any] = {}

    def engine(self, grammar: tuple[str, ...] | None = None) -> Any:
        return _engine(self.options.engine, grammar or self.vocabulary)

    def posterior(self, lk: str, sc: Any) -> Any:
        if lk not in self._posts:
            self._posts[lk] = decision_posterior(lk, sc, self.instr, self.audio, self.engine(), self.options.nbest)
        return self._posts[lk]

    def heard_by(self, lk: str) -> Any:
        if lk not in self._hears:
            self._hears[lk] = decision_heard(lk, self.instr, self.audio, self.engine(), self.options.nbest)
        return self._hears[lk]


@dataclass(frozen=True)
class Trial:
    """One model on one stimulus: what a kind's function is given."""

    model: EvalModel
    stimulus: Stimulus
    scenario: Any
    key: str  # the scenario key: stimuli with the same key share world, actions and gold goal
    heard: TrialHeard
    root: str  # the dataset's folder (clips are relative to it)
    memo: Memo = field(default_factory=dict, compare=False)

    @property
    def options(self) -> EvalOptions:
        return self.heard.options

    def memoised(self, what: str, choose: Callable[[], tuple[str, float]]) -> Choice:
        """``choose()`` once per (scenario key, model, ``what`` was heard)."""
        mk = (self.key, self.model.name, what)
        if mk not in self.memo:
            c, p = choose()
            self.memo[mk] = (c, p, 0.0)
        return Choice(self.memo[mk][0], self.memo[mk][1])


def choose(trial: Trial) -> Choice:
    """The command ``trial.model`` chooses, by the function registered for its kind.

    Raises:
        AnswerUnavailableError: the trial cannot be evaluated for this model (a decision model).
    """
    m = trial.model
    if m.kind == "posterior" and m.likelihood == "auto" and siftom_likelihood(trial.options) == "acoustic":
        return choose_acoustic(trial)  # the product's default path for a recording
    chooser: Callable[[Trial], Choice] = EVAL_KINDS.spec(m.kind).load()
    return chooser(trial)


def choose_literal(t: Trial) -> Choice:
    from siftom.bench.literal import literal_command

    cmd = literal_command(t.heard.tr["text"], t.scenario, max_count=MAX_COUNT)
    return Choice(str(cmd), 1.0) if cmd is not None else Choice("none", 1.0)


def choose_acoustic(t: Trial) -> Choice:
    if t.model.mode == "full":  # the MAP rule on the acoustic posterior (siftom.listen's path)
        post = t.heard.posterior("acoustic", t.scenario)
        return Choice(post.command, float(post.commands[0][1]))
    from siftom.bench.acoustic_models import acoustic_choice  # without the actions

    return t.memoised(t.stimulus.id, lambda: acoustic_choice(
        "speech-only-acoustic", t.scenario, t.heard.audio, t.heard.engine(), t.options.nbest))


def choose_llm_baseline(t: Trial) -> Choice:
    from siftom.bench.llm_baselines import chooser, command_space

    text = t.heard.tr["text"]
    return t.memoised(text, lambda: chooser(t.model.name, t.options.llm).choose(
        t.scenario, text, command_space(t.scenario, MAX_COUNT)))


def choose_decision(t: Trial) -> Choice:
    """A decision rule on a likelihood's posterior, answering through the observer (bench/decisions.py)."""
    h = t.heard
    extra = run_decision_model(t.model.name, t.stimulus, t.scenario, h.heard_by(str(t.model.likelihood)), t.root,
                               lambda x, grammar=None: h.engine(grammar).transcribe(x, nbest=t.options.nbest))
    command, prob = extra.pop("command"), float(extra.pop("prob"))
    return Choice(command, prob, extra)


def _heard_by(t: Trial) -> tuple[Any, str]:
    """(what the model hears, its memo key): the N-best, the clip with its N-best, the reference or nothing."""
    from siftom.observation import Instruction

    spec, s, instr = t.model, t.stimulus, t.heard.instr
    if spec.heard == "reference":
        return Instruction.from_text(s.reference), s.reference
    if spec.heard == "none" or spec.mode == "action-only":
        return None, ""
    if spec.heard == "audio":
        from siftom.bench.acoustic_models import heard

        return heard(t.heard.audio, t.heard.engine(), t.options.nbest)[0], f"audio:{s.id}"
    return instr, json.dumps([(h.text, h.score) for h in instr.nbest]) if instr is not None else ""


def choose_posterior(t: Trial) -> Choice:
    """The MAP command and its probability for a ``posterior`` model (the paper's metric), from
    ``Observer.infer`` under the evaluator's own settings (the ``SIFTOM_*`` environment does not
    change a benchmark)."""
    heard, key = _heard_by(t)
    return t.memoised(key, lambda: _posterior_command(t, heard))


def _posterior_command(t: Trial, heard: Any) -> tuple[str, float]:
    from siftom.observer import observer_for

    spec, opts = t.model, t.options
    if spec.mode == "speech-only" and heard is None:
        return "none", 1.0  # nothing was heard: the robot does nothing
    lk = str(spec.likelihood or "phonetic")
    if lk == "auto":  # the siftom row: the run's likelihood for the transcript, phonetic by default
        lk = "phonetic" if opts.likelihood == "auto" else opts.likelihood
    elif spec.follows_run and opts.likelihood != "auto":
        lk = opts.likelihood
    settings = eval_settings(spec.mode, opts.llm if lk == "llm" else None)  # the run's LLM configuration
    post = observer_for(settings).infer(t.scenario, None, heard, likelihood=lk, decide="map", gate=False)
    return str(post.top_command), post.top_prob
