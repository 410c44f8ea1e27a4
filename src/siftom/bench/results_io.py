"""Result files that stay trustworthy: atomic lines, provenance, one line per stimulus.

* Each line is written with one ``write(2)`` on a file opened ``O_APPEND``: a signal cannot
  split it (Python runs handlers between calls, never inside one), and a hard kill loses at
  most the last line, which the reader drops as torn.
* Every results row carries ``provenance``: siftom's version, a hash of its source code, the
  evaluation options and the dataset's fingerprint. Resuming checks it, so rows made with other
  options or other code are never mixed into one summary.
* Readers refuse a stimulus id that appears twice, naming it.
* Timings (seconds per model, ASR real-time factor) go to ``timings.jsonl``, not the results,
  so that ``results.jsonl`` depends only on the dataset, the options and the code: the same run
  on any backend or number of workers gives the same bytes.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from siftom.errors import DatasetError
from siftom.jsonlines import (
    read_jsonl as read_jsonl,  # re-exported: the result files are JSON lines
)
from siftom.jsonlines import rewrite as rewrite

if TYPE_CHECKING:
    from siftom.bench.models import EvalOptions

TIMINGS = "timings.jsonl"
RESULTS = "results.jsonl"


@lru_cache(maxsize=1)
def code_version() -> dict[str, str]:
    """siftom's version and a hash of every ``.py`` file of the installed package."""
    import siftom

    pkg = Path(siftom.__file__).resolve().parent
    h = hashlib.sha1()
    for p in sorted(pkg.rglob("*.py")):
        h.update(p.relative_to(pkg).as_posix().encode() + b"\0")
        h.update(p.read_bytes() + b"\0")
    return {"siftom": str(getattr(siftom, "__version__", "?")), "source_sha1": h.hexdigest()[:16]}


@dataclass(frozen=True)
class Provenance:
    """How a results row was made: siftom's version and source hash, the evaluation options (their
    JSON form, :meth:`EvalOptions.to_json`) and the dataset's fingerprint; None where an older row
    does not say."""

    siftom: str | None
    source_sha1: str | None
    options: dict[str, Any]
    dataset: str | None

    def to_json(self) -> dict[str, Any]:
        """The ``provenance`` entry of every results row."""
        return {"code": {"siftom": self.siftom, "source_sha1": self.source_sha1}, "options": self.options,
                "dataset": self.dataset}

    @classmethod
    def from_json(cls, data: object) -> Provenance | None:
        """Read a row's ``provenance`` (None when it is not a JSON object: a row of an older siftom)."""
        if not isinstance(data, dict):
            return None
        code = data.get("code", {})
        return cls(code.get("siftom"), code.get("source_sha1"), dict(data.get("options", {})), data.get("dataset"))


def provenance(options: EvalOptions, dataset_fingerprint: str) -> Provenance:
    """This code's provenance for rows evaluated with ``options`` on the dataset of that fingerprint."""
    code = code_version()
    return Provenance(code["siftom"], code["source_sha1"], options.to_json(), dataset_fingerprint)


def provenance_mismatch(old: Provenance | None, new: Provenance) -> list[str]:
    """What differs between a row's provenance and this run's, in words (empty: the same)."""
    if old is None:
        return ["the rows record no provenance (made by an older siftom)"]
    out = []
    if old.dataset != new.dataset:
        out.append("the dataset")
    oo, no = old.options, new.options
    for k in sorted(set(oo) | set(no)):
        if oo.get(k) != no.get(k):
            out.append(f"option {k} ({oo.get(k)!r} then, {no.get(k)!r} now)")
    if (old.siftom, old.source_sha1) != (new.siftom, new.source_sha1):
        out.append(f"the code (siftom {old.siftom} source {old.source_sha1} then, "
                   f"{new.siftom} source {new.source_sha1} now)")
    return out


class AtomicAppender:
    """Append JSON lines, each with a single ``write`` on an ``O_APPEND`` file."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def write(self, obj: dict[str, Any]) -> None:
        data = (json.dumps(obj) + "\n").encode("utf-8")
        n = os.write(self.fd, data)
        while n < len(data):  # a regular file takes it whole; this is for odd file systems
            n += os.write(self.fd, data[n:])

    def close(self) -> None:
        if self.fd >= 0:
            os.fsync(self.fd)
            os.close(self.fd)
            self.fd = -1


def check_unique(ids: Iterable[object], where: str | Path) -> None:
    """Raise DatasetError naming the first stimulus id that appears twice (``ids``: each row's, in order)."""
    seen: dict[str, int] = {}
    for n, i in enumerate(ids, 1):
        if i in seen:
            raise DatasetError(
                f"{where}: stimulus {i!r} appears twice (lines {seen[i]} and {n}), so two runs wrote "
                "into this folder; its metrics would count that trial twice. Evaluate again into a new "
                "--out folder (or pass --overwrite)"
            )
        seen[str(i)] = n


def load_results(out: str | Path) -> list[dict[str, Any]]:
    """Rows of ``RESULTS/results.jsonl``; raise DatasetError when missing or malformed."""
    p = Path(out) / RESULTS
    if not p.is_file():
        raise DatasetError(f"{str(out)!r} has no {RESULTS}; run 'siftom eval --dataset DIR --out {out}' first")
    rows = read_jsonl(p)
    for n, r in enumerate(rows, 1):
        if not isinstance(r, dict) or "id" not in r or not isinstance(r.get("models"), dict):
            raise DatasetError(f"{p}:{n}: a results row needs 'id' and 'models'; the file is not from siftom eval")
    check_unique((r.get("id") for r in rows), p)
    return rows
