"""JSON-lines files read and rewritten safely: a torn last line is dropped, a rewrite is atomic.

Shared by the benchmark's result files (:mod:`siftom.bench.results_io`) and the people pages'
folders (:mod:`siftom.people`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from siftom.errors import DatasetError


def read_jsonl(path: Path, repair: bool = False) -> list[dict[str, Any]]:
    """Lines of a JSONL file; a torn last line (interrupted write) is dropped (and cut if repair)."""
    if not path.is_file():
        return []
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    out = []
    for n, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            if n == len(lines) - 1:
                if repair:
                    with open(path, "r+b") as f:
                        f.truncate(len("".join(lines[:n]).encode("utf-8")))
                break
            raise DatasetError(f"{path}:{n + 1} is not valid JSON; delete the file to start over") from None
    return out


def rewrite(path: Path, rows: Iterable[dict[str, Any]]) -> None:
    """Replace a JSONL file atomically (a temporary file renamed over it)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
