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

Scoring the answers against the models is the bench's (:mod:`siftom.bench.human`).
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

from siftom.errors import DatasetError, NotYoursError
from siftom.jsonlines import read_jsonl
from siftom.people.records import AnnotatorAnswer, AnswerForm, Joined
from siftom.people.stimuli import Dataset, load_dataset, scenario_for
from siftom.private import append_private, private_dir, write_private_text

ANSWERS = "answers.jsonl"
ANNOTATORS = "annotators.jsonl"
PLAN = "plan.json"
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


def answer_form(scenario: Any) -> AnswerForm:
    """What the page's form offers for this scenario: the scene's classes and, to deliver, counts."""
    from siftom.world.commands import MAX_COUNT

    return AnswerForm(scenario.verb, tuple(sorted(scenario.world.classes)),
                      MAX_COUNT if scenario.verb == "deliver" else None)


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

    def join(self, annotator: str | None, key: str | None = None) -> Joined:
        """Give ``annotator`` (a new unguessable id when None) its assignment: the one it had, or the
        first free one; the answer holds ``key``, the annotator's secret (the page's links use it).

        Coming back under an id that has a key needs that key (NotYoursError otherwise).
        """
        from siftom.people.collect import key_digest, key_matches

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
        return Joined(annotator, given, known[annotator], len(self.assignments[known[annotator]]))

    def annotator_for(self, key: str) -> str:
        """The annotator whose key this is; NotYoursError for any other string."""
        from siftom.people.collect import key_matches

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
               seconds: float | None = None) -> AnnotatorAnswer:
        """Store one answer (a position answered twice keeps the first answer)."""
        s = self.stimulus_at(annotator, position)
        command = answer_command(scenario_for(s), item, count)
        typed = " ".join(str(typed).split())[:500]
        rec = AnnotatorAnswer(annotator, position, s.id, typed, command,
                              None if seconds is None else round(float(seconds), 1),
                              time.strftime("%Y-%m-%dT%H:%M:%S%z"))
        with self._lock:
            if position in self.answered(annotator):
                raise DatasetError(f"position {position} is already answered; go on to the next stimulus")
            with append_private(self.root / ANSWERS) as f:
                f.write(json.dumps(rec.to_json()) + "\n")
        return rec
