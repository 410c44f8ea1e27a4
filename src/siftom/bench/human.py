"""The human baseline: people hear each stimulus, type what they heard and pick what they would bring.

As in the paper's annotation study, an annotator sees the scenario (what the person has done;
not the goal), plays the (noisy) recording, types what was said, and chooses the item and count
they would bring, one stimulus per page. Each stimulus is shown to ``per_stimulus`` annotators.

Assignments: a stimulus's *source* is its recording (the scenario and the speaker: the clean clip
and its noisy copies). In each of ``per_stimulus`` rounds the conditions of every source are
dealt in a seeded random order over as many layers as a source has conditions, so each layer
holds every source once; each layer is shuffled and cut into assignments of ``per_annotator``
stimuli (default: the whole layer, 130 stimuli of the paper's 520). An annotator gets the first
assignment nobody has taken: nobody hears the same recording twice (clean and noisy would give
the noisy one away), and once every assignment is done every stimulus has been heard exactly
``per_stimulus`` times. The plan is written to ``OUT/plan.json``; answers go to
``OUT/answers.jsonl`` as they come (one JSON line each).

Annotators: a new one gets an unguessable id (``a-`` and 8 random characters, never a1, a2, ...)
and a secret key (``secrets.token_urlsafe``; ``annotators.jsonl`` keeps only its SHA-256). The
page reaches the annotator's recordings and answers through the key, so nobody can hear or
answer another annotator's assignment, and an id that is taken needs its key to continue.

Scoring (:func:`score_answers`) turns every answer into a trial of a model named ``human``:
its command is scored against the gold one and simulated by the same team simulation as the
models (agents/team.py), and the typed text is compared with the reference (word error rate).
The rows go to ``RESULTS/human.jsonl``, which ``siftom report`` puts next to the models. Every
answer is a trial: the confidence intervals resample answers, not stimuli.
"""

from __future__ import annotations

import json
import re
import secrets
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.results_io import read_jsonl, rewrite
from siftom.bench.stimuli import Dataset, load_dataset, scenario_for
from siftom.errors import DatasetError, NotYoursError
from siftom.private import append_private, private_dir, write_private_text

ANSWERS = "answers.jsonl"
ANNOTATORS = "annotators.jsonl"
PLAN = "plan.json"
HUMAN_RESULTS = "human.jsonl"
HUMAN = "human"
NOTHING = "none"  # the answer "I would bring nothing"
ANNOTATOR_ID = re.compile(r"[A-Za-z0-9_-]{1,32}")
ANNOTATOR_CONSENT = (
    "You will hear short recordings of people asking a robot for help, some with background noise. "
    "For each one, type what you heard and choose what you would bring. Your answers and the "
    "annotator id below are saved on this computer only and are not sent anywhere. Taking part is "
    "voluntary and you can stop at any time."
)


@dataclass(frozen=True)
class AnnotateOptions:
    """How to run an annotation. Validated at construction.

    Attributes:
        per_stimulus: annotators per stimulus.
        per_annotator: stimuli per annotator (None: one of each recording, in one condition).
        seed: drives the order of the stimuli and the assignments.
        consent: the text annotators agree to first.
    """

    per_stimulus: int = 3
    per_annotator: int | None = None
    seed: int = 0
    consent: str = ANNOTATOR_CONSENT

    def __post_init__(self) -> None:
        if self.per_stimulus < 1:
            raise DatasetError(f"--per-stimulus must be >= 1, got {self.per_stimulus}")
        if self.per_annotator is not None and self.per_annotator < 1:
            raise DatasetError(f"--per-annotator must be >= 1, got {self.per_annotator}")

    def to_json(self) -> dict[str, Any]:
        return {"per_stimulus": self.per_stimulus, "per_annotator": self.per_annotator, "seed": self.seed}


def plan_assignments(items: list[tuple[str, str]], per_stimulus: int, per_annotator: int | None,
                     seed: int) -> list[list[str]]:
    """Assignments of stimulus ids from ``(id, source)`` pairs; no assignment holds a source twice."""
    rng = np.random.default_rng([seed, 2601])
    groups: dict[str, list[str]] = {}
    for sid, source in items:
        groups.setdefault(source, []).append(sid)
    slots = max(len(g) for g in groups.values())
    out: list[list[str]] = []
    for _ in range(per_stimulus):
        layers: list[list[str]] = [[] for _ in range(slots)]
        for source in sorted(groups):
            g = groups[source]
            offset = int(rng.integers(slots))  # sources with fewer conditions spread over the layers
            for j, k in enumerate(rng.permutation(len(g))):
                layers[(j + offset) % slots].append(g[k])
        for layer in layers:
            order = [layer[i] for i in rng.permutation(len(layer))]
            m = per_annotator or len(order)
            out += [order[i:i + m] for i in range(0, len(order), m)]
    return out


def source_of(stimulus: Any) -> str:
    """The recording a stimulus comes from: its scenario and speaker (clean and noisy copies share it)."""
    return f"{stimulus.scenario}#{stimulus.scenario_seed}#{stimulus.speaker}"


def answer_command(scenario: Any, item: str, count: int | None) -> str:
    """The robot command an annotator's choice stands for (``none`` for nothing); DatasetError if invalid."""
    from siftom.world.commands import MAX_COUNT

    if item == NOTHING:
        return NOTHING
    if item not in scenario.world.classes:
        raise DatasetError(f"item {item!r} is not in this scene; choose one of the list (or 'nothing')")
    if scenario.verb == "fetch":
        return f"fetch({item})"
    if not isinstance(count, int) or not 1 <= count <= MAX_COUNT:
        raise DatasetError(f"choose how many {item} to bring: a number from 1 to {MAX_COUNT}")
    return f"deliver({item},{count})"


def answer_form(scenario: Any) -> dict[str, Any]:
    """What the page's form offers for this scenario: the scene's classes and, to deliver, counts."""
    from siftom.world.commands import MAX_COUNT

    return {"verb": scenario.verb, "classes": sorted(scenario.world.classes),
            "max_count": MAX_COUNT if scenario.verb == "deliver" else None}


class Annotation:
    """An annotation folder: the plan, who has which assignment, the answers (thread-safe)."""

    def __init__(self, dataset: str | Path | Dataset, out: str | Path, options: AnnotateOptions | None = None) -> None:
        self.ds = dataset if isinstance(dataset, Dataset) else load_dataset(dataset)
        self.options = options or AnnotateOptions()
        self.root = Path(out)
        private_dir(self.root)
        self._lock = threading.Lock()
        self.index = {s.id: k for k, s in enumerate(self.ds.stimuli)}
        plan_path = self.root / PLAN
        want = {"dataset": str(self.ds.root.resolve()), "dataset_fingerprint": self.ds.fingerprint,
                "options": self.options.to_json()}
        if plan_path.is_file():
            plan = json.loads(plan_path.read_text(encoding="utf-8"))
            if plan.get("dataset_fingerprint") != self.ds.fingerprint or plan.get("options") != want["options"]:
                raise DatasetError(f"{self.root} holds an annotation of another dataset or with other options "
                                   f"({plan.get('options')}); use another --out folder")
        else:
            items = [(s.id, source_of(s)) for s in self.ds.stimuli]
            plan = {**want, "assignments": plan_assignments(items, self.options.per_stimulus,
                                                            self.options.per_annotator, self.options.seed)}
            write_private_text(plan_path, json.dumps(plan, indent=1) + "\n")
        self.assignments: list[list[str]] = plan["assignments"]

    # -- annotators -----------------------------------------------------------------------------

    def _annotators(self) -> dict[str, int]:
        return {r["annotator"]: int(r["assignment"]) for r in read_jsonl(self.root / ANNOTATORS)}

    def _digests(self) -> dict[str, str]:
        """annotator -> the SHA-256 of its key ('' for one who joined before keys existed)."""
        return {r["annotator"]: str(r.get("key_sha256") or "") for r in read_jsonl(self.root / ANNOTATORS)}

    def join(self, annotator: str | None, key: str | None = None) -> dict[str, Any]:
        """Give ``annotator`` (a new unguessable id when None) its assignment: the one it had, or the
        first free one; the answer holds ``key``, the annotator's secret (the page's links use it).

        Coming back under an id that has a key needs that key (NotYoursError otherwise).
        """
        from siftom.bench.collect import key_digest, key_matches

        if annotator is not None and not ANNOTATOR_ID.fullmatch(annotator):
            raise DatasetError(f"annotator id {annotator!r} is not valid: use 1-32 letters, digits, '_' or '-'")
        with self._lock:
            known = self._annotators()
            digests = self._digests()
            if annotator is None:
                annotator = "a-" + secrets.token_urlsafe(6)
                while annotator in known:
                    annotator = "a-" + secrets.token_urlsafe(6)
            if annotator in known and digests.get(annotator):
                if not key_matches(key, digests[annotator]):
                    raise NotYoursError(f"annotator id {annotator!r} is taken; continue with the link you were "
                                        "given, or leave the id empty to get a new one")
                given = str(key)
            else:
                given = secrets.token_urlsafe(24)
                if annotator in known:  # joined before keys existed: this key is its first
                    assignment = known[annotator]
                else:
                    taken = set(known.values())
                    free = [k for k in range(len(self.assignments)) if k not in taken]
                    if not free:
                        raise DatasetError(f"every assignment is taken: each stimulus already has "
                                           f"{self.options.per_stimulus} annotator(s); score the answers with "
                                           "siftom report RESULTS --human OUT")
                    assignment = free[0]
                rec = {"annotator": annotator, "assignment": assignment, "agreed": True,
                       "at": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "consent": self.options.consent,
                       "key_sha256": key_digest(given)}
                with append_private(self.root / ANNOTATORS) as f:
                    f.write(json.dumps(rec) + "\n")
                known[annotator] = assignment
        return {"annotator": annotator, "key": given, "assignment": known[annotator],
                "total": len(self.assignments[known[annotator]])}

    def annotator_for(self, key: str) -> str:
        """The annotator whose key this is; NotYoursError for any other string."""
        from siftom.bench.collect import key_matches

        for annotator, digest in self._digests().items():
            if key_matches(key, digest):
                return annotator
        raise NotYoursError("this link belongs to no annotator here; open the link you were given, or start "
                            "again on the first page")

    def assignment(self, annotator: str) -> list[str]:
        known = self._annotators()
        if annotator not in known:
            raise DatasetError(f"annotator {annotator!r} has not started; agree on the first page first")
        return self.assignments[known[annotator]]

    def answered(self, annotator: str) -> set[int]:
        return {int(a["position"]) for a in read_jsonl(self.root / ANSWERS) if a.get("annotator") == annotator}

    def next_position(self, annotator: str) -> int | None:
        """The first position of the annotator's assignment without an answer (None: done)."""
        done = self.answered(annotator)
        return next((k for k in range(len(self.assignment(annotator))) if k not in done), None)

    def stimulus_at(self, annotator: str, position: int) -> Any:
        ids = self.assignment(annotator)
        if not 0 <= position < len(ids):
            raise DatasetError(f"position {position} is outside this assignment (0 to {len(ids) - 1})")
        return self.ds.stimuli[self.index[ids[position]]]

    def answer(self, annotator: str, position: int, typed: str, item: str, count: int | None,
               seconds: float | None = None) -> dict[str, Any]:
        """Store one answer (a position answered twice keeps the first answer)."""
        s = self.stimulus_at(annotator, position)
        command = answer_command(scenario_for(s), item, count)
        typed = " ".join(str(typed).split())[:500]
        rec = {"annotator": annotator, "position": position, "id": s.id, "typed": typed, "command": command,
               "seconds": None if seconds is None else round(float(seconds), 1),
               "at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        with self._lock:
            if position in self.answered(annotator):
                raise DatasetError(f"position {position} is already answered; go on to the next stimulus")
            with append_private(self.root / ANSWERS) as f:
                f.write(json.dumps(rec) + "\n")
        return rec


# -- scoring -----------------------------------------------------------------------------------

def score_answers(annotation: str | Path, results: str | Path, dataset: str | Path | None = None) -> list[dict[str, Any]]:
    """Score ``ANNOTATION/answers.jsonl`` as trials of the model ``human``; write ``RESULTS/human.jsonl``.

    The dataset is the one the annotation was planned on (``dataset`` when given, else the folder
    recorded in the plan, else the one ``RESULTS`` evaluated: a moved folder is found); ``RESULTS``
    must be an evaluation of the same dataset (its team simulations are reused).
    """
    from siftom.bench import trials
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
        trial = {"command": cmd, "correct": trials.is_correct(cmd, s.gold_command, sc.verb),
                 "helpful": trials.is_helpful(cmd, s.gold_goal["counts"]), "l_single": team["l_single"],
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


def human_summary(rows: list[dict[str, Any]], seed: int = 0) -> dict[str, Any]:
    """How well people transcribed: mean WER with a bootstrap CI, by SNR; answers, annotators, stimuli."""
    from siftom.bench.metrics import bootstrap_ci, group_key, label_order

    w = np.array([r["wer"] for r in rows], dtype=float)
    lo, hi = bootstrap_ci(w, seed=seed + 2)
    by: dict[str, list[float]] = {}
    for r in rows:
        by.setdefault(group_key(r, "snr"), []).append(r["wer"])
    per = [sum(1 for r in rows if r["id"] == i) for i in {r["id"] for r in rows}]
    return {"answers": len(rows), "annotators": len({r["annotator"] for r in rows}),
            "stimuli": len({r["id"] for r in rows}), "answers_per_stimulus": round(float(np.mean(per)), 2),
            "wer": round(float(w.mean()), 4), "wer_ci": [round(lo, 4), round(hi, 4)],
            "wer_by_snr": {k: round(float(np.mean(by[k])), 4) for k in sorted(by, key=label_order)}}


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def people_section(summary: dict[str, Any]) -> str:
    """The report's Markdown section on people: the human baseline's transcripts and the ratings."""
    parts: list[str] = []
    h = summary.get("human")
    if h:
        asr = summary.get("asr_wer", {})
        parts += ["## The human baseline", "",
                  f"{h['answers']} answers from {h['annotators']} annotator(s) on {h['stimuli']} stimuli "
                  f"({h['answers_per_stimulus']:g} per stimulus); each answer is one trial of the model `human` "
                  "in the tables above (its command went through the same team simulation).", "",
                  f"Transcription word error rate: people {_pct(h['wer'])} [{100 * h['wer_ci'][0]:.1f}, "
                  f"{100 * h['wer_ci'][1]:.1f}], the recogniser {_pct(asr.get('all'))}.", "",
                  "| condition | people WER | ASR WER |", "|---|---|---|"]
        parts += [f"| {k} | {_pct(v)} | {_pct(asr.get('snr', {}).get(k))} |" for k, v in h["wer_by_snr"].items()]
        parts += [""]
    r = summary.get("ratings")
    if r:
        from siftom.bench.ratings import STATEMENTS

        parts += ["## Ratings after trials with the robot", "",
                  "Mean of three statements rated from 1 (strongly disagree) to 7 (strongly agree), per trial; "
                  "95 % bootstrap CI over trials.", ""]
        parts += [f"{k + 1}. {s}" for k, s in enumerate(STATEMENTS)]
        parts += ["", "| model | mean rating [95 % CI] | SD | statement 1 | statement 2 | statement 3 | trials |",
                  "|---|---|---|---|---|---|---|"]
        for m, v in r.items():
            st = " | ".join(f"{x:.2f}" for x in v["statements"])
            parts.append(f"| {m} | {v['mean']:.2f} [{v['mean_ci'][0]:.2f}, {v['mean_ci'][1]:.2f}] | {v['sd']:.2f} "
                         f"| {st} | {v['n']} |")
        parts += [""]
    return "\n".join(parts) + ("\n" if parts else "")
