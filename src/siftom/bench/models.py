"""The evaluator's models: each a registered entry (what it hears × the likelihood × the decision rule).

``siftom eval --models`` takes any name of :data:`EVAL_MODELS`, one registry of the shape every
plug-in uses (siftom/registry.py). An entry's ``attrs`` say what the model is:

* ``kind``: how a trial is run, a registered function of :data:`EVAL_KINDS`
  (bench/choosers.py; a plug-in registers its own): ``posterior`` (SIFToM's posterior through
  the observer, the MAP command),
  ``decision`` (a decision rule on the posterior: bench/decisions.py), ``acoustic`` (the
  acoustic likelihood as ``siftom.listen`` hears the clip: bench/acoustic_models.py),
  ``literal`` (the recogniser's words read literally) or ``llm-baseline`` (bench/llm_baselines.py);
* ``likelihood``: a registered instruction likelihood (``auto``: the product's default for a
  recording, or the run's ``--likelihood``);
* ``mode``: ``full``, ``speech-only`` or ``action-only``;
* ``heard``: ``nbest`` (the evaluator's recogniser's N-best), ``audio`` (the clip and its
  N-best), ``reference`` (what the speaker said: the oracle) or ``none``;
* ``rule``: the decision rule (``map`` for the posterior models).

Every registered likelihood is evaluable with no edit to siftom: a likelihood ``L`` that no
built-in model runs gets the model ``siftom-L`` (the full model, MAP rule, scoring the N-best,
or the clip when the likelihood needs audio). A plug-in package registers its likelihood by
entry point (siftom/registry.py) and ``siftom eval --models siftom-L`` runs it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from siftom.errors import DatasetError, unknown_name
from siftom.people.stimuli import check_seed
from siftom.registry import Registry
from siftom.speech.asr import DEFAULT_NBEST

if TYPE_CHECKING:
    from siftom.settings import Settings
    from siftom.settings.llm import LLMConfig

# how a kind of model chooses a command: a function (trial) -> Choice (bench/choosers.py)
EVAL_KINDS = Registry("evaluator kind", default="posterior")
for _kind, _summary in (
    ("posterior", "SIFToM's posterior through the observer; the MAP command (the paper's metric)"),
    ("decision", "a decision rule on SIFToM's posterior, answering through the observer"),
    ("acoustic", "the acoustic likelihood as siftom.listen hears the clip"),
    ("literal", "the recogniser's 1-best read literally (a baseline; no inference)"),
    ("llm-baseline", "an LLM chooses the command (a baseline; no inverse planning)"),
):
    EVAL_KINDS.register(_kind, f"siftom.bench.choosers:choose_{_kind.replace('-', '_')}", summary=_summary)
HEARD = ("nbest", "audio", "reference", "none")
DEFAULT_ENGINE = "pocketsphinx-vocab"  # the evaluator's: recognition biased to the scene's phrasings

EVAL_MODELS = Registry("evaluator model", default="siftom")
_ENTRY = "siftom.bench.models:EvalModel"


@dataclass(frozen=True)
class EvalModel:
    """One evaluator model (module doc): resolved from its registry entry by :func:`eval_model`."""

    name: str
    kind: str
    likelihood: str | None = None
    mode: str = "full"
    heard: str = "nbest"
    rule: str = "map"
    default: bool = False  # in ``siftom eval``'s default list
    needs_llm: bool = False  # an LLM must be configured (docs/llm.md)
    follows_run: bool = False  # the run's ``--likelihood`` (when given) replaces ``likelihood``

    def __post_init__(self) -> None:
        if not self.kind:  # the kind is looked up in EVAL_KINDS by EvalOptions (plug-ins may add kinds)
            raise DatasetError(f"evaluator model {self.name!r}: give its kind (one of EVAL_KINDS in "
                               "siftom.bench.models)")
        if self.heard not in HEARD:
            raise DatasetError(f"evaluator model {self.name!r}: heard must be one of {', '.join(HEARD)}, "
                               f"got {self.heard!r}")

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "likelihood": self.likelihood, "mode": self.mode,
                "heard": self.heard, "rule": self.rule}


def register_eval_model(name: str, summary: str = "", **attrs: Any) -> None:
    """Add an evaluator model (``attrs``: the fields of :class:`EvalModel` but ``name``)."""
    EvalModel(name, **attrs)  # validate now, not at the first trial
    EVAL_MODELS.register(name, _ENTRY, summary=summary, attrs=attrs)


_BUILTIN: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("literal-asr", "the recogniser's 1-best read literally (no inference)", {"kind": "literal", "default": True}),
    ("speech-only", "SIFToM's speech term alone: uniform prior, no actions (phonetic)",
     {"kind": "posterior", "likelihood": "phonetic", "mode": "speech-only", "default": True, "follows_run": True}),
    ("action-only", "the actions alone, nothing heard", {"kind": "posterior", "likelihood": None,
                                                         "mode": "action-only", "heard": "none", "default": True}),
    ("siftom", "the product's default for a recording (acoustic with the whisper extra, else phonetic)",
     {"kind": "posterior", "likelihood": "auto", "default": True}),
    ("siftom-phonetic", "SIFToM on the N-best's phonemes", {"kind": "posterior", "likelihood": "phonetic",
                                                            "default": True}),
    ("siftom-oracle-text", "SIFToM on what the speaker said (the ceiling of recognition)",
     {"kind": "posterior", "likelihood": "phonetic", "heard": "reference", "default": True,
      "follows_run": True}),
    ("siftom-eb", "expected benefit on the acoustic posterior (docs/decisions.md)",
     {"kind": "decision", "likelihood": "acoustic", "rule": "expected-benefit", "heard": "audio", "default": True}),
    ("siftom-ask", "ask-or-act on the acoustic posterior: it may ask a question",
     {"kind": "decision", "likelihood": "acoustic", "rule": "ask-or-act", "heard": "audio", "default": True}),
    ("siftom-teammate", "the teammate rule (the product's default) on the acoustic posterior: it acts on a "
     "request understood, else asks", {"kind": "decision", "likelihood": "acoustic", "rule": "teammate",
                                       "heard": "audio", "default": True}),
    ("siftom-phonetic-teammate", "the teammate rule on the phonetic posterior",
     {"kind": "decision", "likelihood": "phonetic", "rule": "teammate"}),
    ("siftom-phonetic-eb", "expected benefit on the phonetic posterior",
     {"kind": "decision", "likelihood": "phonetic", "rule": "expected-benefit"}),
    ("siftom-phonetic-ask", "ask-or-act on the phonetic posterior",
     {"kind": "decision", "likelihood": "phonetic", "rule": "ask-or-act"}),
    ("siftom-acoustic", "the acoustic likelihood as siftom.listen hears the clip",
     {"kind": "acoustic", "likelihood": "acoustic", "heard": "audio"}),
    ("speech-only-acoustic", "the acoustic likelihood with no actions",
     {"kind": "acoustic", "likelihood": "acoustic", "mode": "speech-only", "heard": "audio"}),
    ("siftom-llm", "SIFToM with the LLM likelihood", {"kind": "posterior", "likelihood": "llm", "needs_llm": True}),
    ("llm-end-to-end", "an LLM chooses the command from the transcript and actions",
     {"kind": "llm-baseline", "needs_llm": True}),
    ("llm-ablated-siftom", "an LLM given SIFToM's inputs without the inverse planner",
     {"kind": "llm-baseline", "needs_llm": True}),
)
for _name, _summary, _attrs in _BUILTIN:
    register_eval_model(_name, _summary, **_attrs)
_BUILTIN_LIKELIHOODS = {a.get("likelihood") for _n, _s, a in _BUILTIN}
# the built-in lists by role (static: reading them loads no plug-in)
MODELS = tuple(n for n, _s, a in _BUILTIN if a.get("default"))
OPTIONAL_MODELS = tuple(n for n, _s, a in _BUILTIN if a.get("needs_llm"))
LLM_BASELINES = tuple(n for n, _s, a in _BUILTIN if a["kind"] == "llm-baseline")
ACOUSTIC_MODELS = tuple(n for n, _s, a in _BUILTIN if a["kind"] == "acoustic")
DECISION_MODELS: dict[str, tuple[str, str]] = {
    n: (str(a["likelihood"]), str(a["rule"])) for n, _s, a in _BUILTIN if a["kind"] == "decision"}


def _from_likelihoods() -> None:
    """``siftom-L`` for every registered likelihood L no built-in model runs (module doc)."""
    from siftom.likelihood.registry import LIKELIHOODS

    for lk, entry in LIKELIHOODS.entries().items():
        if lk in _BUILTIN_LIKELIHOODS:
            continue
        heard = "audio" if entry.attrs.get("needs_audio") else "nbest"
        EVAL_MODELS.register(f"siftom-{lk}", _ENTRY, summary=f"SIFToM with the {lk} likelihood (MAP rule)",
                             requires=entry.requires, extra=entry.extra,
                             attrs={"kind": "posterior", "likelihood": lk, "heard": heard})


EVAL_MODELS.on_first_use(_from_likelihoods)


def eval_model(name: str) -> EvalModel:
    """The model registered as ``name``; unknown names raise UnknownNameError with close names."""
    return EvalModel(name, **EVAL_MODELS.spec(name).attrs)


def eval_model_names() -> tuple[str, ...]:
    """Every evaluator model: the default list first (in report order), then the others."""
    names = EVAL_MODELS.entries()
    builtin = [n for n, _s, _a in _BUILTIN]
    return tuple(builtin + sorted(n for n in names if n not in builtin))


def default_models(llm: bool = False) -> tuple[str, ...]:
    """``siftom eval``'s default list; with ``llm``, the LLM models too."""
    out = [n for n in eval_model_names() if eval_model(n).default]
    if llm:
        out += [n for n in eval_model_names() if eval_model(n).needs_llm]
    return tuple(out)


def decision_models() -> Mapping[str, tuple[str, str]]:
    """Decision models: name -> (likelihood, rule)."""
    out: dict[str, tuple[str, str]] = {}
    for n in eval_model_names():
        m = eval_model(n)
        if m.kind == "decision":
            out[n] = (str(m.likelihood), m.rule)
    return out


@dataclass(frozen=True)
class EvalOptions:
    """How to evaluate. Validated at construction.

    Attributes:
        models: evaluator model names (:data:`EVAL_MODELS`), in report order.
        engine: ``pocketsphinx-vocab`` (a trigram LM built from the domain's command phrasings),
            ``pocketsphinx`` (generic LM) or ``whisper`` (faster-whisper).
        nbest: ASR hypotheses kept for the N-best models.
        likelihood: the ``siftom`` row's instruction likelihood; ``auto`` (default): the product's
            default for a recording (acoustic with the whisper extra, else phonetic).
            ``siftom-phonetic`` always runs the phonetic one.
        seed: seed of the bootstrap.
        llm: the language model of the LLM models (default: ``SIFTOM_LLM_*``).
    """

    models: tuple[str, ...] = field(default_factory=default_models)
    engine: str = DEFAULT_ENGINE
    nbest: int = DEFAULT_NBEST
    likelihood: str = "auto"
    seed: int = 0
    llm: Any = None  # siftom.backends.config.LLMConfig

    def __post_init__(self) -> None:
        check_seed(self.seed)
        if not self.models:
            raise DatasetError(f"give at least one model; available: {', '.join(eval_model_names())}")
        for m in self.models:
            if m not in EVAL_MODELS:
                raise unknown_name("model", m, eval_model_names())
            EVAL_MODELS.check(m)  # a plug-in's model whose extra is missing: the pip install that fixes it
            EVAL_KINDS.check(eval_model(m).kind)  # an unknown kind names the registered ones
        if len(set(self.models)) != len(self.models):
            raise DatasetError(f"a model is listed twice: {', '.join(self.models)}")
        from siftom.speech.asr.base import ENGINES

        ENGINES.spec(self.engine)  # unknown names suggest close matches
        if self.nbest < 1:
            raise DatasetError(f"--nbest must be >= 1, got {self.nbest}")
        if self.likelihood != "auto":
            from siftom.likelihood.registry import LIKELIHOODS

            LIKELIHOODS.spec(self.likelihood)

    def model(self, name: str) -> EvalModel:
        return eval_model(name)

    def to_json(self) -> dict[str, Any]:
        """Plain dict (stored in run.json)."""
        out: dict[str, Any] = {"models": list(self.models), "engine": self.engine, "nbest": self.nbest,
                               "likelihood": self.likelihood}
        chosen = [eval_model(m) for m in self.models]
        if self.llm is not None and any(m.needs_llm for m in chosen):
            out["llm"] = {k: v for k, v in self.llm.to_json().items() if k in ("backend", "base_url", "model", "prompt")}
        if "siftom" in self.models:
            out["siftom_likelihood"] = siftom_likelihood(self)
        plugins = [m.to_json() for m in chosen if m.name not in {n for n, _s, _a in _BUILTIN}]
        if plugins:
            out["plugin_models"] = plugins
        if any(m.likelihood == "acoustic" for m in chosen) or out.get("siftom_likelihood") == "acoustic":
            from siftom.likelihood.acoustic import DEFAULT_WHISPER_TEMPERATURE
            from siftom.likelihood.whisper_factor import whisper_available

            out["acoustic"] = {"whisper": whisper_available(), "whisper_temperature": DEFAULT_WHISPER_TEMPERATURE,
                               "whisper_listen": whisper_available()}  # Whisper's own words as a second carrier
        return out


@lru_cache(maxsize=8)
def eval_settings(mode: str, llm: LLMConfig | None = None) -> Settings:
    """The settings the evaluator runs SIFToM with: the defaults (not the ``SIFTOM_*`` environment:
    a benchmark does not change with it), in ``mode``, with the run's language model ``llm`` (the
    ``--llm-*`` options); every row goes through their observer."""
    from siftom.settings import Settings

    flags: dict[str, Any] = {"model.mode": mode}
    if llm is not None:
        flags.update({f"llm.{f.name}": getattr(llm, f.name) for f in dataclasses.fields(llm)
                      if getattr(llm, f.name) is not None})
    return Settings.load(env={}, flags=flags)


def siftom_likelihood(opts: EvalOptions) -> str:
    """The instruction likelihood of the ``siftom`` row: the product's default for a recording
    (acoustic with the whisper extra, else phonetic) unless the options name one."""
    from siftom.likelihood.registry import resolve_likelihood

    return resolve_likelihood(opts.likelihood, has_audio=True)[0]
