"""The human baseline scored, and the report's section on people.

The annotation itself (the page's plan, annotators and answers) is :mod:`siftom.people.annotate`.
Scoring (:func:`score_answers`) turns every answer into a trial of a model named ``human``:
its command is scored against the gold one and simulated by the same team simulation as the
models (agents/team.py), and the typed text is compared with the reference (word error rate).
The rows go to ``RESULTS/human.jsonl``, which ``siftom report`` puts next to the models. Every
answer is a trial: the confidence intervals resample answers, not stimuli. People's ratings of
the robot (:mod:`siftom.people.ratings`) are summarised per model by :func:`ratings_summary`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.results_io import read_jsonl, rewrite
from siftom.errors import DatasetError
from siftom.people.annotate import ANSWERS, PLAN
from siftom.people.stimuli import load_dataset, scenario_for

HUMAN_RESULTS = "human.jsonl"
HUMAN = "human"


# -- scoring -----------------------------------------------------------------------------------

def score_answers(annotation: str | Path, results: str | Path, dataset: str | Path | None = None) -> list[dict[str, Any]]:
    """Score ``ANNOTATION/answers.jsonl`` as trials of the model ``human``; write ``RESULTS/human.jsonl``.

    The dataset is the one the annotation was planned on (``dataset`` when given, else the folder
    recorded in the plan, else the one ``RESULTS`` evaluated: a moved folder is found); ``RESULTS``
    must be an evaluation of the same dataset (its team simulations are reused).
    """
    from siftom.bench import trials
    from siftom.bench.scoring import is_correct, is_helpful
    from siftom.speech.metrics import wer

    ann, res = Path(annotation), Path(results)
    plan_path = ann / PLAN
    if not plan_path.is_file():
        raise DatasetError(f"{str(ann)!r} has no {PLAN}; give the --out folder of 'siftom annotate'")
    plan = json.loads(plan_path.read_text(encoding="utf-8"))
    run_path = res / "run.json"
    run = json.loads(run_path.read_text(encoding="utf-8")) if run_path.is_file() else {}
    where = next((str(p) for p in (dataset, plan.get("dataset"), run.get("dataset"))
                  if p is not None and Path(p).is_dir()), str(dataset or plan.get("dataset")))
    ds = load_dataset(where, check_audio=False)
    if ds.fingerprint != plan["dataset_fingerprint"]:
        raise DatasetError(f"the dataset {where} is not the one annotated in {ann} (its manifest differs: a new "
                           "recording or another mix); annotate this version into another folder")
    if run.get("dataset_fingerprint") not in (None, ds.fingerprint):
        raise DatasetError(f"{res} evaluates another dataset than the one annotated in {ann} ({where}); "
                           "give the results of 'siftom eval --dataset' on that dataset")
    for t in read_jsonl(res / "team_cache.jsonl"):  # the models' team simulations, reused
        trials._TEAM.setdefault((t["key"], t["command"]), t)
    stim = {s.id: s for s in ds.stimuli}
    order = {s.id: k for k, s in enumerate(ds.stimuli)}
    answers = read_jsonl(ann / ANSWERS)
    rows = []
    for a in sorted(answers, key=lambda a: (order.get(a["id"], len(order)), a["annotator"])):
        s = stim.get(a["id"])
        if s is None:
            raise DatasetError(f"{ann / ANSWERS}: stimulus {a['id']!r} is not in {where}")
        sc = scenario_for(s)
        cmd = a["command"]
        team = trials._simulate(trials.scenario_key(s), sc, cmd)
        trial = {"command": cmd, "correct": is_correct(cmd, s.gold_command, sc.verb),
                 "helpful": is_helpful(cmd, s.gold_goal["counts"]), "l_single": team["l_single"],
                 "l_team": team["l_team"], "remedy_steps": team["remedy_steps"],
                 "speedup": None if team["speedup"] is None else round(team["speedup"], 6)}
        if team.get("error"):
            trial["speedup_error"] = team["error"]
        rows.append({"id": s.id, "annotator": a["annotator"], "scenario": s.scenario, "speaker": s.speaker,
                     "voice": s.voice, "noise": s.noise, "snr_db": s.snr_db, "condition": s.condition,
                     "reference": s.reference, "gold_command": s.gold_command, "typed": a["typed"],
                     "wer": round(wer(s.reference, a["typed"]), 4), "models": {HUMAN: trial}})
    if not rows:
        raise DatasetError(f"{ann / ANSWERS} holds no answers yet; annotate first (siftom annotate)")
    res.mkdir(parents=True, exist_ok=True)
    rewrite(res / HUMAN_RESULTS, rows)
    return rows


def load_human(results: str | Path) -> list[dict[str, Any]]:
    """The scored human answers of a results folder (empty when there are none)."""
    return read_jsonl(Path(results) / HUMAN_RESULTS)


@dataclass(frozen=True)
class HumanSummary:
    """How well people transcribed: answers, annotators, stimuli, answers per stimulus, the mean word
    error rate with its bootstrap CI, and the mean per SNR label."""

    answers: int
    annotators: int
    stimuli: int
    answers_per_stimulus: float
    wer: float
    wer_ci: tuple[float, float]
    wer_by_snr: dict[str, float]

    def to_json(self) -> dict[str, Any]:
        """The ``human`` entry of summary.json."""
        return {"answers": self.answers, "annotators": self.annotators, "stimuli": self.stimuli,
                "answers_per_stimulus": self.answers_per_stimulus, "wer": self.wer, "wer_ci": list(self.wer_ci),
                "wer_by_snr": self.wer_by_snr}


@dataclass(frozen=True)
class RatingSummary:
    """One model's ratings: trials, the mean per trial of the three statements with its CI and
    standard deviation, and each statement's mean."""

    n: int
    mean: float
    mean_ci: tuple[float, float]
    sd: float
    statements: tuple[float, ...]

    def to_json(self) -> dict[str, Any]:
        """The model's entry in summary.json's ``ratings``."""
        return {"n": self.n, "mean": self.mean, "mean_ci": list(self.mean_ci), "sd": self.sd,
                "statements": list(self.statements)}


def human_summary(rows: list[dict[str, Any]], seed: int = 0) -> HumanSummary:
    """How well people transcribed: mean WER with a bootstrap CI, by SNR; answers, annotators, stimuli."""
    from siftom.bench.metrics import bootstrap_ci, group_key, label_order

    w = np.array([r["wer"] for r in rows], dtype=float)
    lo, hi = bootstrap_ci(w, seed=seed + 2)
    by: dict[str, list[float]] = {}
    for r in rows:
        by.setdefault(group_key(r, "snr"), []).append(r["wer"])
    per = [sum(1 for r in rows if r["id"] == i) for i in {r["id"] for r in rows}]
    return HumanSummary(len(rows), len({r["annotator"] for r in rows}), len({r["id"] for r in rows}),
                        round(float(np.mean(per)), 2), round(float(w.mean()), 4), (round(lo, 4), round(hi, 4)),
                        {k: round(float(np.mean(by[k])), 4) for k in sorted(by, key=label_order)})


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def people_section(human: HumanSummary | None, ratings: Mapping[str, RatingSummary],
                   asr_wer: float | None = None, asr_wer_by_snr: Mapping[str, float] | None = None) -> str:
    """The report's Markdown section on people: the human baseline's transcripts (beside the
    recogniser's word error rate, overall and per SNR label) and the ratings."""
    parts: list[str] = []
    h = human
    if h:
        by_snr = asr_wer_by_snr or {}
        parts += ["## The human baseline", "",
                  f"{h.answers} answers from {h.annotators} annotator(s) on {h.stimuli} stimuli "
                  f"({h.answers_per_stimulus:g} per stimulus); each answer is one trial of the model `human` "
                  "in the tables above (its command went through the same team simulation).", "",
                  f"Transcription word error rate: people {_pct(h.wer)} [{100 * h.wer_ci[0]:.1f}, "
                  f"{100 * h.wer_ci[1]:.1f}], the recogniser {_pct(asr_wer)}.", "",
                  "| condition | people WER | ASR WER |", "|---|---|---|"]
        parts += [f"| {k} | {_pct(v)} | {_pct(by_snr.get(k))} |" for k, v in h.wer_by_snr.items()]
        parts += [""]
    r = ratings
    if r:
        from siftom.people.ratings import STATEMENTS

        parts += ["## Ratings after trials with the robot", "",
                  "Mean of three statements rated from 1 (strongly disagree) to 7 (strongly agree), per trial; "
                  "95 % bootstrap CI over trials.", ""]
        parts += [f"{k + 1}. {s}" for k, s in enumerate(STATEMENTS)]
        parts += ["", "| model | mean rating [95 % CI] | SD | statement 1 | statement 2 | statement 3 | trials |",
                  "|---|---|---|---|---|---|---|"]
        for m, v in r.items():
            st = " | ".join(f"{x:.2f}" for x in v.statements)
            parts.append(f"| {m} | {v.mean:.2f} [{v.mean_ci[0]:.2f}, {v.mean_ci[1]:.2f}] | {v.sd:.2f} "
                         f"| {st} | {v.n} |")
        parts += [""]
    return "\n".join(parts) + ("\n" if parts else "")


def ratings_summary(rows: list[dict[str, Any]], seed: int = 0) -> dict[str, RatingSummary]:
    """Per model: mean of the three statements per trial (helpfulness) with a CI, and each statement's mean."""
    from siftom.bench.metrics import bootstrap_ci

    out: dict[str, RatingSummary] = {}
    for m in sorted({r["model"] for r in rows}):
        s = np.array([r["scores"] for r in rows if r["model"] == m], dtype=float)
        per_trial = s.mean(axis=1)
        lo, hi = bootstrap_ci(per_trial, seed=seed + 3)
        out[m] = RatingSummary(len(s), round(float(per_trial.mean()), 3), (round(lo, 3), round(hi, 3)),
                               round(float(per_trial.std(ddof=1)) if len(s) > 1 else 0.0, 3),
                               tuple(round(float(v), 3) for v in s.mean(axis=0)))
    return out
