"""People's ratings of the robot after a trial (paper, Human-Robot Experiment, Metrics).

After a trial with a session of the service, the participant rates three statements on a
7-point Likert scale (1 = strongly disagree, 7 = strongly agree); their mean is the trial's
helpfulness. The service stores one JSON line per rating in ``DATA_DIR/ratings.jsonl`` with the
model the session ran; ``siftom report RESULTS --ratings FILE`` copies them into the results
folder and reports the mean per model with a bootstrap CI
(:func:`siftom.bench.human.ratings_summary`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from siftom.errors import DatasetError
from siftom.jsonlines import read_jsonl

RATINGS = "ratings.jsonl"
SCALE = (1, 7)
STATEMENTS = (
    "The robot performed the task as expected, considering the difficulty of the task.",
    "The robot understood what I needed.",
    "The robot performed on par with or better than what I would expect from a human.",
)


def session_model(mode: str, likelihood: str) -> str:
    """The evaluator's name for the model a session ran (``siftom``, ``speech-only``, ...)."""
    if mode == "full":
        # the evaluator's rows: "siftom" is the default path ("auto"), "siftom-phonetic" the N-best one
        return "siftom" if likelihood == "auto" else f"siftom-{likelihood}"
    return mode


def check_scores(scores: Any) -> list[int]:
    """Three integers from 1 to 7, one per statement; DatasetError otherwise."""
    lo, hi = SCALE
    if (not isinstance(scores, list | tuple) or len(scores) != len(STATEMENTS)
            or not all(isinstance(x, int) and not isinstance(x, bool) and lo <= x <= hi for x in scores)):
        raise DatasetError(f"give {len(STATEMENTS)} ratings, each a whole number from {lo} "
                           f"(strongly disagree) to {hi} (strongly agree); got {scores!r}")
    return list(scores)


def import_ratings(source: str | Path, results: str | Path) -> int:
    """Add the ratings of ``source`` (a ratings.jsonl) to ``RESULTS/ratings.jsonl``; return how many were new."""
    src = Path(source)
    if src.is_dir():
        src = src / RATINGS
    if not src.is_file():
        raise DatasetError(f"{str(src)!r} does not exist; give the ratings.jsonl in the service's --data-dir")
    new = read_jsonl(src)
    for n, r in enumerate(new, 1):
        if not isinstance(r, dict) or "id" not in r or "model" not in r:
            raise DatasetError(f"{src}:{n}: a rating needs 'id', 'model' and 'scores'; is this a ratings file?")
        check_scores(r.get("scores"))
    dest = Path(results) / RATINGS
    have = read_jsonl(dest)
    seen = {r["id"] for r in have}
    add = [r for r in new if r["id"] not in seen]
    if add:
        tmp = dest.with_name(f".{RATINGS}.{os.getpid()}.tmp")
        tmp.write_text("".join(json.dumps(r) + "\n" for r in [*have, *add]), encoding="utf-8")
        os.replace(tmp, dest)
    return len(add)
