"""Evaluate models on a dataset: transcribe each stimulus once, run every model, simulate the team.

Models (names as in ``summary.json``):

* ``literal-asr``: the 1-best transcript read by a classic command parser (``literal.py``);
* ``speech-only``: SIFToM's instruction likelihood alone over the N-best list, uniform prior;
* ``action-only``: SIFToM's goal inference from the observed actions alone (no speech);
* ``siftom``: the full model, actions + N-best transcript;
* ``siftom-oracle-text``: the full model given the reference transcript (an upper bound);
* ``siftom-llm``: the full model with the paper's LLM instruction likelihood (``likelihood/llm.py``);
  with ``llm-end-to-end`` and ``llm-ablated-siftom`` it runs only when an LLM is configured;
* on request, ``siftom-acoustic`` and ``speech-only-acoustic``: the audio itself (bench/acoustic_models.py).

Per stimulus the chosen command is scored against the gold one (object class and count exact;
class only for ``fetch`` domains), called a helpful error when wrong but its class is part of
the goal, and simulated (agents/team.py) for L_single, L_team, remedy steps and speedup.

Operation: work is grouped by scenario so that a worker process reuses the scenario's planner
tables and team simulations; each finished stimulus is appended to ``results.jsonl`` at once,
so an interrupted run resumes where it stopped. Transcripts and team simulations are cached in
the results folder (``transcripts.jsonl``, ``team_cache.jsonl``).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from siftom.bench.decisions import DECISION_MODELS, decision_fields, run_decision_model
from siftom.bench.results_io import (
    TIMINGS,
    AtomicAppender,
    check_unique,
    provenance,
    provenance_mismatch,
    read_jsonl,
    rewrite,
    split_timings,
)
from siftom.bench.runlock import RunLock, stop_on_signals
from siftom.bench.stimuli import Dataset, Stimulus, load_dataset, scenario_for
from siftom.errors import DatasetError, SiftomError, unknown_name

MODELS = ("literal-asr", "speech-only", "action-only", "siftom", "siftom-oracle-text", "siftom-eb", "siftom-ask")
# run only when a language model is configured (siftom.bench.llm_baselines)
OPTIONAL_MODELS = ("siftom-llm", "llm-end-to-end", "llm-ablated-siftom")
LLM_BASELINES = ("llm-end-to-end", "llm-ablated-siftom")
ACOUSTIC_MODELS = ("siftom-acoustic", "speech-only-acoustic")
ENGINES = ("pocketsphinx-vocab", "pocketsphinx-open", "pocketsphinx", "whisper")
DEFAULT_ENGINE = "pocketsphinx-vocab"
RESULTS = "results.jsonl"
RUN = "run.json"
TRANSCRIPTS = "transcripts.jsonl"
TEAM_CACHE = "team_cache.jsonl"
MAX_COUNT = 4  # the largest count in the command space (ModelConfig.max_count)


@dataclass(frozen=True)
class EvalOptions:
    """How to evaluate. Validated at construction.

    Attributes:
        models: model names (see module doc), in report order.
        engine: ``pocketsphinx-vocab`` (a trigram LM built from the domain's command phrasings),
            ``pocketsphinx`` (generic LM) or ``whisper`` (faster-whisper).
        nbest: ASR hypotheses kept for the N-best models.
        likelihood: SIFToM's instruction likelihood (``phonetic``).
        seed: seed of the bootstrap.
        llm: the language model of the LLM models (default: ``SIFTOM_LLM_*``).
    """

    models: tuple[str, ...] = MODELS
    engine: str = DEFAULT_ENGINE
    nbest: int = 5
    likelihood: str = "phonetic"
    seed: int = 0
    llm: Any = None  # siftom.backends.config.LLMConfig

    def __post_init__(self) -> None:
        if not self.models:
            raise DatasetError(f"give at least one model; available: {', '.join(MODELS)}")
        for m in self.models:
            if m not in MODELS + OPTIONAL_MODELS + ACOUSTIC_MODELS:
                raise unknown_name("model", m, MODELS + OPTIONAL_MODELS + ACOUSTIC_MODELS)
        if len(set(self.models)) != len(self.models):
            raise DatasetError(f"a model is listed twice: {', '.join(self.models)}")
        if self.engine not in ENGINES:
            raise unknown_name("ASR engine", self.engine, ENGINES)
        if self.nbest < 1:
            raise DatasetError(f"--nbest must be >= 1, got {self.nbest}")

    def to_json(self) -> dict[str, Any]:
        """Plain dict (stored in run.json)."""
        out = {"models": list(self.models), "engine": self.engine, "nbest": self.nbest,
               "likelihood": self.likelihood}
        if self.llm is not None and set(self.models) & set(OPTIONAL_MODELS):
            out["llm"] = {k: v for k, v in self.llm.public().items() if k in ("backend", "base_url", "model")}
        return out


@dataclass
class EvalRun:
    """What an evaluation did: rows in manifest order, how many were new, timings."""

    out: Path
    rows: list[dict[str, Any]]
    resumed: int
    evaluated: int
    seconds: float
    counters: dict[str, float] = field(default_factory=dict)


# -- per-process state (engines, caches) -------------------------------------------------------

_ENGINES: dict[tuple[str, str], Any] = {}
_TEAM: dict[tuple[str, str], dict[str, Any]] = {}


def asr_vocabulary(classes: Sequence[str], verb: str, max_count: int = MAX_COUNT) -> tuple[str, ...]:
    """Every phrasing of every command over ``classes``: the domain LM's training sentences."""
    from siftom.likelihood.phrasing import command_vocabulary

    return tuple(command_vocabulary(sorted(set(classes)), verb, max_count))


def _engine(name: str, vocabulary: tuple[str, ...]) -> Any:
    from siftom.speech.asr.base import get_engine

    scene = name in ("pocketsphinx-vocab", "pocketsphinx-open")
    key = (name, hashlib.sha1("\n".join(vocabulary).encode()).hexdigest() if scene else "")
    if key not in _ENGINES:
        if scene:
            # -vocab: the scene's phrasings alone; -open: mixed with frequent English words
            # (open vocabulary, docs/speech.md)
            from siftom.speech.asr.pocketsphinx import OPEN_BACKGROUND_WORDS

            extra = {"background_words": OPEN_BACKGROUND_WORDS} if name == "pocketsphinx-open" else {}
            _ENGINES[key] = get_engine("pocketsphinx", vocabulary=list(vocabulary), **extra)
        else:
            _ENGINES[key] = get_engine(name)
    return _ENGINES[key]


def scenario_key(s: Stimulus) -> str:
    """Stimuli with the same key share the world, the observed actions and the gold goal."""
    h = hashlib.sha1("\n".join(s.observed_actions).encode()).hexdigest()[:10]
    return f"{s.scenario}#{s.scenario_seed}#{h}"


def _simulate(skey: str, sc: Any, command: str) -> dict[str, Any]:
    """Team simulation of a command string (``none``: the robot does nothing), cached."""
    from siftom.agents.team import simulate_scenario
    from siftom.world.commands import RobotCommand

    key = (skey, command)
    if key not in _TEAM:
        t0 = time.perf_counter()
        try:
            r = simulate_scenario(sc, None if command == "none" else RobotCommand.parse(command))
        except SiftomError as exc:  # a planning budget ran out: keep the trial, without a speedup
            _TEAM[key] = {"l_single": None, "l_team": None, "remedy_steps": None, "speedup": None,
                          "useful": None, "wrong": None, "error": str(exc),
                          "seconds": round(time.perf_counter() - t0, 3)}
            return _TEAM[key]
        _TEAM[key] = {"l_single": r.l_single, "l_team": r.l_team, "remedy_steps": r.remedy_steps,
                      "speedup": r.speedup, "useful": r.useful, "wrong": r.wrong,
                      "seconds": round(time.perf_counter() - t0, 3)}
    return _TEAM[key]


def is_correct(command: str, gold: str, verb: str) -> bool:
    """Object class and count exact (class only for ``fetch``); ``none`` is never correct."""
    if command == "none":
        return False
    from siftom.world.commands import RobotCommand

    c, g = RobotCommand.parse(command), RobotCommand.parse(gold)
    if verb == "fetch":
        return c.obj_class == g.obj_class
    return c.obj_class == g.obj_class and c.count == g.count


def is_helpful(command: str, goal_counts: dict[str, Any]) -> bool:
    """A command whose class is part of the human's goal."""
    if command == "none":
        return False
    from siftom.world.commands import RobotCommand

    return RobotCommand.parse(command).obj_class in goal_counts


def _instruction(nbest: Sequence[dict[str, Any]]) -> Any:
    from siftom.observation import Hypothesis, Instruction

    hyps = tuple(Hypothesis(h["text"], float(h["score"])) for h in nbest if h["text"].strip())
    return Instruction(nbest=hyps) if hyps else None


def _wer(reference: str, text: str) -> float:
    from siftom.speech.metrics import wer

    return wer(reference, text)


@dataclass(frozen=True)
class _Task:
    root: str
    stimuli: tuple[Stimulus, ...]
    options: EvalOptions
    vocabulary: tuple[str, ...]
    transcripts: dict[str, dict[str, Any]]
    team: dict[str, dict[str, Any]]


def _eval_stimuli(task: _Task) -> Iterator[tuple[dict[str, Any], dict[str, Any] | None, list[dict[str, Any]]]]:
    """Yield (results row, new transcript or None, new team simulations) per stimulus."""
    from siftom.api import get_model
    from siftom.bench.literal import literal_command
    from siftom.inference.model import Observation
    from siftom.observation import Instruction

    opts = task.options
    root = Path(task.root)
    for s in task.stimuli:
        skey = scenario_key(s)
        for c, r in task.team.items():
            _TEAM.setdefault((skey, c), r)
    memo: dict[tuple[str, str, str], tuple[str, float, float]] = {}
    for s in task.stimuli:
        sc = scenario_for(s)
        skey = scenario_key(s)
        new_tr = None
        tr = task.transcripts.get(s.id)
        if tr is None:
            audio = Path(s.audio) if Path(s.audio).is_absolute() else root / s.audio
            t = _engine(opts.engine, task.vocabulary).transcribe(audio, nbest=opts.nbest)
            tr = {"id": s.id, "engine": opts.engine, "text": t.text,
                  "nbest": [{"text": h.text, "score": round(float(h.score), 4)} for h in t.nbest][: opts.nbest],
                  "rtf": round(t.rtf, 4), "audio_s": round(t.audio_s, 3)}
            new_tr = tr
        instr = _instruction(tr["nbest"]) if tr["nbest"] else _instruction([{"text": tr["text"], "score": 0.0}])
        before = set(_TEAM)
        models: dict[str, Any] = {}
        for m in opts.models:
            t0 = time.perf_counter()
            prob = float("nan")
            extra: dict[str, Any] = {}
            if m == "literal-asr":
                cmd = literal_command(tr["text"], sc, max_count=MAX_COUNT)
                command, prob = (str(cmd), 1.0) if cmd is not None else ("none", 1.0)
            elif m in ACOUSTIC_MODELS:  # siftom.api.listen's path: VAD, ASR word times, key-phrase alignment
                from siftom.bench.acoustic_models import acoustic_choice
                command, prob = acoustic_choice(m, sc, Path(s.audio) if Path(s.audio).is_absolute() else root / s.audio,
                                                _engine(opts.engine, task.vocabulary), opts.nbest)
            elif m in LLM_BASELINES:
                from siftom.bench.llm_baselines import chooser, command_space

                mk = (skey, m, tr["text"])
                if mk not in memo:
                    c_, p_ = chooser(m, opts.llm).choose(sc, tr["text"], command_space(sc, MAX_COUNT))
                    memo[mk] = (c_, p_, 0.0)
                command, prob, _ = memo[mk]
            elif m in DECISION_MODELS:  # decision rules and questions: bench/decisions.py
                extra = run_decision_model(m, s, sc, instr, opts.likelihood, task.root,
                                           lambda x: _engine(opts.engine, task.vocabulary).transcribe(x, nbest=opts.nbest))
                command, prob = extra.pop("command"), float(extra.pop("prob"))
            else:
                mode = {"speech-only": "speech-only", "action-only": "action-only"}.get(m, "full")
                if m == "siftom-oracle-text":
                    heard = Instruction.from_text(s.reference)
                    mk = (skey, m, s.reference)
                elif m == "action-only":
                    heard, mk = None, (skey, m, "")
                else:
                    heard = instr
                    mk = (skey, m, json.dumps(tr["nbest"]))
                if mk in memo:
                    command, prob, _ = memo[mk]
                elif mode == "speech-only" and heard is None:
                    command, prob = "none", 1.0  # nothing was heard: the robot does nothing
                else:
                    lk = "llm" if m == "siftom-llm" else opts.likelihood
                    post = get_model(mode, lk, opts.llm).infer(Observation.from_scenario(sc, heard))
                    command, prob = post.command, float(post.commands[0][1])
                memo[mk] = (command, prob, 0.0)
            team = _simulate(skey, sc, command)
            models[m] = {
                "command": command, "prob": round(prob, 4),
                "correct": is_correct(command, s.gold_command, sc.verb),
                "helpful": is_helpful(command, s.gold_goal["counts"]),
                "l_single": team["l_single"], "l_team": team["l_team"],
                "remedy_steps": team["remedy_steps"],
                "speedup": None if team["speedup"] is None else round(team["speedup"], 6),
                "seconds": round(time.perf_counter() - t0, 4),
            }
            if extra:
                models[m].update(decision_fields(extra, team))
            if team.get("error"):  # no speedup: say why (summary.json counts these)
                models[m]["speedup_error"] = team["error"]
        gold = _simulate(skey, sc, s.gold_command)
        row = {
            "id": s.id, "scenario": s.scenario, "speaker": s.speaker, "voice": s.voice,
            "noise": s.noise, "snr_db": s.snr_db, "condition": s.condition, "style": s.style,
            "reference": s.reference, "gold_command": s.gold_command, "gold_goal": s.gold_goal.get("name", ""),
            "gold_speedup": None if gold["speedup"] is None else round(gold["speedup"], 6),
            "transcript": {"text": tr["text"], "nbest": tr["nbest"], "engine": tr["engine"],
                           "rtf": tr["rtf"], "wer": round(_wer(s.reference, tr["text"]), 4)},
            "models": models,
        }
        new_team = [{"key": k[0], "command": k[1], **_TEAM[k]} for k in set(_TEAM) - before]
        yield row, new_tr, new_team


def _run_task(task: _Task, vocabulary: tuple[str, ...]) -> list[tuple[dict[str, Any], dict[str, Any] | None, list[dict[str, Any]]]]:
    """One scenario group on a worker; the vocabulary is shipped once per worker, not per task."""
    return list(_eval_stimuli(replace(task, vocabulary=vocabulary)))


# -- files ---------------------------------------------------------------------------------

_read_jsonl = read_jsonl  # the name older code imports


def load_results(out: str | Path) -> list[dict[str, Any]]:
    """Rows of ``RESULTS/results.jsonl``; raise DatasetError when missing or malformed."""
    p = Path(out) / RESULTS
    if not p.is_file():
        raise DatasetError(f"{str(out)!r} has no {RESULTS}; run 'siftom eval --dataset DIR --out {out}' first")
    rows = _read_jsonl(p)
    for n, r in enumerate(rows, 1):
        if not isinstance(r, dict) or "id" not in r or not isinstance(r.get("models"), dict):
            raise DatasetError(f"{p}:{n}: a results row needs 'id' and 'models'; the file is not from siftom eval")
    check_unique(rows, p)
    return rows


def evaluate(
    dataset: str | Path | Dataset,
    out: str | Path,
    options: EvalOptions | None = None,
    workers: int = 1,
    overwrite: bool = False,
    progress: Callable[[int, int], None] | None = None,
    backend: Any = None,
) -> EvalRun:
    """Evaluate every model on every stimulus not yet in ``out/results.jsonl``.

    The run owns ``out`` while it works (a second run on it is refused, see bench/runlock.py);
    SIGINT and SIGTERM stop it and its workers, raising RunInterrupted, and leave a folder that
    resumes. ``results.jsonl`` ends in manifest order and without timings (``timings.jsonl``),
    so it is the same, byte for byte, on every backend.

    Args:
        dataset: a dataset folder (or a loaded Dataset).
        out: the results folder (created).
        options: models, engine, N-best size, likelihood, bootstrap seed.
        workers: processes (1 = in this process), or Ray CPUs.
        overwrite: start over when ``out`` holds a run with other settings or data.
        progress: called with (stimuli done, total) after each stimulus.
        backend: ``"local"`` (default), ``"ray"`` or a backend object (bench/backends.py);
            one given as an object is left running for the caller.

    Raises:
        DatasetError: malformed dataset, or ``out`` holds another run (and not ``overwrite``).
        RunLockedError: another live process is writing into ``out``.
    """
    from siftom.bench.backends import make_backend

    opts = options or EvalOptions()
    ds = dataset if isinstance(dataset, Dataset) else load_dataset(dataset)
    root = Path(out)
    with RunLock(root), stop_on_signals():
        owned = backend is None or isinstance(backend, str)
        be = make_backend(backend or "local", workers) if owned else backend
        try:
            return _evaluate(ds, root, opts, be, overwrite, progress)
        finally:
            if owned:
                getattr(be, "shutdown", be.close)()


def _evaluate(ds: Dataset, root: Path, opts: EvalOptions, be: Any, overwrite: bool,
              progress: Callable[[int, int], None] | None) -> EvalRun:
    run_info = {"dataset": str(ds.root.resolve()), "dataset_fingerprint": ds.fingerprint,
                "options": opts.to_json(), "seed": opts.seed}
    prov = provenance(opts.to_json(), ds.fingerprint)
    run_path = root / RUN
    old: dict[str, Any] = {}
    if run_path.is_file():
        try:
            old = json.loads(run_path.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            old = {}
    if overwrite:
        for name in (RESULTS, TRANSCRIPTS, TEAM_CACHE, TIMINGS):
            (root / name).unlink(missing_ok=True)
    t0 = time.perf_counter()
    old_rows = _read_jsonl(root / RESULTS, repair=True)
    check_unique(old_rows, root / RESULTS)
    for n, r in enumerate(old_rows, 1):  # every row says how it was made: another run's rows are refused
        differs = provenance_mismatch(r.get("provenance"), prov)
        if differs:
            raise DatasetError(
                f"{root} holds results of another run ({root / RESULTS}:{n} differs in {'; '.join(differs)}); "
                "resume with the same options and code, use another --out folder, or pass --overwrite"
            )
    done = {r["id"]: r for r in old_rows}
    valid = {s.id for s in ds.stimuli}
    done = {k: v for k, v in done.items() if k in valid}
    cached_tr = {t["id"]: t for t in _read_jsonl(root / TRANSCRIPTS, repair=True) if t.get("engine") == opts.engine}
    cached_team: dict[str, dict[str, dict[str, Any]]] = {}
    for t in _read_jsonl(root / TEAM_CACHE, repair=True):
        cached_team.setdefault(t["key"], {})[t["command"]] = t
    _read_jsonl(root / TIMINGS, repair=True)
    pending = [s for s in ds.stimuli if s.id not in done]
    history = [] if overwrite else list(old.get("history", [])) if old.get("dataset_fingerprint") == ds.fingerprint else []
    started = time.strftime("%Y-%m-%dT%H:%M:%S")
    run_info["history"] = history
    run_info["code"] = prov["code"]
    _write_json(run_path, run_info)

    # the ASR vocabulary covers every class of every scenario in the dataset
    classes: set[str] = set()
    verbs: set[str] = set()
    for s in ds.stimuli:
        sc = scenario_for(s)
        classes.update(sc.world.classes)
        verbs.add(sc.verb)
    vocab = tuple(v for verb in sorted(verbs) for v in asr_vocabulary(sorted(classes), verb))
    if opts.engine in ("pocketsphinx-vocab", "pocketsphinx-open") and pending and be.name == "local":
        _engine(opts.engine, vocab)  # build the LM once, before pool workers fork and race to build it

    groups: OrderedDict[str, list[Stimulus]] = OrderedDict()
    for s in pending:
        groups.setdefault(scenario_key(s), []).append(s)
    tasks = [_Task(str(ds.root), tuple(g), opts, vocab if be.inline else (),
                   {s.id: cached_tr[s.id] for s in g if s.id in cached_tr},
                   cached_team.get(k, {})) for k, g in groups.items()]
    res_f, tr_f, team_f, tim_f = (AtomicAppender(root / n) for n in (RESULTS, TRANSCRIPTS, TEAM_CACHE, TIMINGS))
    n_done = len(done)
    total = len(ds.stimuli)

    def consume(row: dict[str, Any], new_tr: dict[str, Any] | None, new_team: list[dict[str, Any]]) -> None:
        nonlocal n_done
        if new_tr is not None:
            tr_f.write(new_tr)
        for t in new_team:
            team_f.write(t)
        row, timing = split_timings(row)
        row["provenance"] = prov
        tim_f.write(timing)
        res_f.write(row)  # last: a stimulus counts as done once its caches are saved
        done[row["id"]] = row
        n_done += 1
        if progress:
            progress(n_done, total)

    try:
        if progress:
            progress(n_done, total)
        if be.inline:
            for task in tasks:
                for item in _eval_stimuli(task):
                    consume(*item)
        else:
            # biggest groups first keeps every worker busy until the end
            order = sorted(tasks, key=lambda t: -len(t.stimuli))
            results = be.map_unordered(_run_task, order, shared=vocab)
            try:
                for _, items in results:
                    for item in items:
                        consume(*item)
            finally:
                results.close()
                be.close()
    finally:
        for f in (res_f, tr_f, team_f, tim_f):
            f.close()
    seconds = time.perf_counter() - t0
    rows = [done[s.id] for s in ds.stimuli if s.id in done]
    if len(rows) == total:
        rewrite(root / RESULTS, rows)  # manifest order: the same bytes on every backend
    counters = {
        "asr_audio_s": sum(t.get("audio_s", 0.0) for t in cached_tr.values()),
        "team_simulations": sum(1 for _ in _read_jsonl(root / TEAM_CACHE)),
    }
    this = {"started": started, "finished": time.strftime("%Y-%m-%dT%H:%M:%S"), "seconds": round(seconds, 1),
            "resumed": total - len(pending), "evaluated": len(pending), "workers": be.workers,
            "backend": be.name}
    run_info["history"] = [*history, this]
    run_info["seconds"] = round(sum(h["seconds"] for h in run_info["history"]), 1)
    _write_json(run_path, run_info)
    return EvalRun(root, rows, total - len(pending), len(pending), seconds, counters)


def _write_json(path: Path, obj: dict[str, Any]) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(obj, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)
