"""One stimulus through every model: transcribe (once), choose a command, score it, simulate the team.

:func:`evaluate_stimuli` is what each worker runs for a group of stimuli of one scenario
(:mod:`siftom.bench.evaluate` orchestrates the run, the files and the backends). Per-process
caches keep ASR engines and team simulations across the stimuli a worker sees.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from siftom.assist.decide import DEFAULT_ASK_COST
from siftom.bench.answers import AnswerUnavailableError
from siftom.bench.choosers import Memo, Trial, TrialHeard, choose, instruction_from
from siftom.bench.decisions import oracle_action
from siftom.bench.engines import engine as _engine
from siftom.bench.models import EvalOptions, eval_model
from siftom.bench.scoring import is_correct, is_helpful
from siftom.errors import SiftomError
from siftom.people.stimuli import Stimulus, load_dataset, scenario_for
from siftom.world.commands import MAX_COUNT

ROOM_FIELDS = ("room_name", "distance_m", "rt60_s")  # a stimulus's room, copied into its results row

# -- per-process state (engines, caches) -------------------------------------------------------

_TEAM: dict[tuple[str, str], dict[str, Any]] = {}


def asr_vocabulary(classes: Sequence[str], verb: str, max_count: int = MAX_COUNT) -> tuple[str, ...]:
    """Every phrasing of every command over ``classes``: the domain LM's training sentences."""
    from siftom.likelihood.phrasing import command_vocabulary

    return tuple(command_vocabulary(sorted(set(classes)), verb, max_count))


def dataset_vocabulary(stimuli: Sequence[Stimulus]) -> tuple[str, ...]:
    """The ASR vocabulary of a dataset: every phrasing over every class of every scenario in it."""
    classes: set[str] = set()
    verbs: set[str] = set()
    for s in stimuli:
        sc = scenario_for(s)
        classes.update(sc.world.classes)
        verbs.add(sc.verb)
    return tuple(v for verb in sorted(verbs) for v in asr_vocabulary(sorted(classes), verb))


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


def saved_trials(dataset: str | Path, results: str | Path) -> Iterator[tuple[Any, Any, dict[str, Any], Any]]:
    """(stimulus, scenario, result row, instruction or None) for each row of an eval results
    folder, to re-score what was heard with other likelihoods without re-running recognition.
    The instruction is the saved N-best list (or the 1-best text when no list was kept)."""
    stimuli = {s.id: s for s in load_dataset(dataset, check_audio=False).stimuli}
    with open(Path(results) / "results.jsonl", encoding="utf-8") as f:
        rows = [json.loads(line) for line in f if line.strip()]
    for r in rows:
        s = stimuli[r["id"]]
        nbest = r["transcript"]["nbest"] or [{"text": r["transcript"]["text"], "score": 0.0}]
        yield s, scenario_for(s), r, instruction_from(nbest, r["transcript"].get("engine"))


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


@dataclass(frozen=True)
class _Finished:
    """One stimulus evaluated: its results row, its transcript when made now (None: it was cached)
    and the team simulations run for it now (the lines of the run's cache files)."""

    row: dict[str, Any]
    transcript: dict[str, Any] | None
    team: list[dict[str, Any]]


def _transcript(task: _Task, s: Stimulus) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """(the stimulus's transcript, the same when it was made now, else None): cached or recognised."""
    tr = task.transcripts.get(s.id)
    if tr is not None:
        return tr, None
    opts = task.options
    audio = Path(s.audio) if Path(s.audio).is_absolute() else Path(task.root) / s.audio
    t = _engine(opts.engine, task.vocabulary).transcribe(audio, nbest=opts.nbest)
    tr = {"id": s.id, "engine": opts.engine, "text": t.text,
          "nbest": [{"text": h.text, "score": round(float(h.score), 4)} for h in t.nbest][: opts.nbest],
          "rtf": round(t.rtf, 4), "audio_s": round(t.audio_s, 3)}
    return tr, tr


def _rounded(speedup: float | None) -> float | None:
    return None if speedup is None else round(speedup, 6)


def _model_row(s: Stimulus, sc: Any, command: str, prob: float, extra: Mapping[str, Any],
               team: dict[str, Any], t0: float) -> dict[str, Any]:
    """A model's entry of a results row: its choice, its score and the team's speedup with it."""
    row = {
        "command": command, "prob": round(prob, 4),
        "correct": is_correct(command, s.gold_command, sc.verb),
        "helpful": is_helpful(command, s.gold_goal["counts"]),
        "l_single": team["l_single"], "l_team": team["l_team"],
        "remedy_steps": team["remedy_steps"],
        "speedup": _rounded(team["speedup"]),
        "seconds": round(time.perf_counter() - t0, 4),
    }
    if extra:
        row.update(_decision_fields(extra, team))
    if team.get("error"):  # no speedup: say why (summary.json counts these)
        row["speedup_error"] = team["error"]
    return row


def _decision_fields(extra: Mapping[str, Any], team: dict[str, Any]) -> dict[str, Any]:
    """Fields a decision model adds to its results entry; a question's cost is added to L_team."""
    out = dict(extra)
    if extra.get("asked") and team.get("l_team") is not None:
        l_team = team["l_team"] + float(extra.get("ask_cost", DEFAULT_ASK_COST))
        out["l_team"] = l_team
        out["speedup"] = round(team["l_single"] / l_team - 1.0, 6) if l_team > 0 else 0.0
    return out


def _oracle(s: Stimulus, sc: Any, skey: str, oracles: dict[tuple[str, str], str]) -> tuple[str, dict[str, Any]]:
    """The goal-known oracle: the best action for the true goal (the report's regret)."""
    if (skey, s.gold_command) not in oracles:
        oracles[(skey, s.gold_command)] = oracle_action(sc, s.gold_command)
    return max(((c, _simulate(skey, sc, c)) for c in dict.fromkeys((oracles[(skey, s.gold_command)],
                                                                     s.gold_command, "none"))),
               key=lambda ct: -np.inf if ct[1]["speedup"] is None else ct[1]["speedup"])


def _eval_stimuli(task: _Task) -> Iterator[_Finished]:
    """Yield what each stimulus's evaluation leaves, stimulus by stimulus."""
    for s in task.stimuli:
        skey = scenario_key(s)
        for c, r in task.team.items():
            _TEAM.setdefault((skey, c), r)
    memo: Memo = {}
    oracles: dict[tuple[str, str], str] = {}
    for s in task.stimuli:
        sc = scenario_for(s)
        skey = scenario_key(s)
        tr, new_tr = _transcript(task, s)
        h = TrialHeard(task.options, task.vocabulary,
                       Path(s.audio) if Path(s.audio).is_absolute() else Path(task.root) / s.audio, tr)
        before = set(_TEAM)
        models: dict[str, Any] = {}
        not_evaluable: dict[str, str] = {}  # model -> why this trial could not be evaluated for it
        for m in task.options.models:
            t0 = time.perf_counter()
            try:
                command, prob, extra = choose(Trial(eval_model(m), s, sc, skey, h, task.root, memo))
            except AnswerUnavailableError as exc:  # this trial cannot be evaluated for m; the others go on
                not_evaluable[m] = str(exc)
                continue
            models[m] = _model_row(s, sc, command, prob, extra, _simulate(skey, sc, command), t0)
        gold = _simulate(skey, sc, s.gold_command)
        best = _oracle(s, sc, skey, oracles)
        row = {
            "id": s.id, "scenario": s.scenario, "speaker": s.speaker, "voice": s.voice,
            "noise": s.noise, "snr_db": s.snr_db, "condition": s.condition, "style": s.style,
            "reference": s.reference, "gold_command": s.gold_command, "gold_goal": s.gold_goal.get("name", ""),
            "gold_speedup": _rounded(gold["speedup"]),
            "oracle": {"command": best[0], "speedup": _rounded(best[1]["speedup"])},
            "transcript": {"text": tr["text"], "nbest": tr["nbest"], "engine": tr["engine"],
                           "rtf": tr["rtf"], "wer": round(_wer(s.reference, tr["text"]), 4)},
            "models": models,
            **{k: s.extra[k] for k in ROOM_FIELDS if k in s.extra},  # where the clip was heard (--rooms)
            **({"not_evaluable": not_evaluable} if not_evaluable else {}),
        }
        new_team = [{"key": k[0], "command": k[1], **_TEAM[k]} for k in set(_TEAM) - before]
        yield _Finished(row, new_tr, new_team)


def _run_task(task: _Task, vocabulary: tuple[str, ...]) -> list[_Finished]:
    """One scenario group on a worker; the vocabulary is shipped once per worker, not per task."""
    return list(_eval_stimuli(replace(task, vocabulary=vocabulary)))
