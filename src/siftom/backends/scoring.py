"""The contract every language-model backend meets: log P(target | prompt) from token log-probs.

A scorer receives one shared prefix (the few-shot prompt) and many (context, target) pairs,
and returns log P(target | prefix + context) summed over the target's tokens. Sharing the
prefix lets an in-process model evaluate it once; a remote endpoint simply concatenates.
"""

from __future__ import annotations

import hashlib
import sqlite3
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, runtime_checkable


@runtime_checkable
class TextScorer(Protocol):
    """Scores continuations of a prompt with a language model."""

    model_id: str

    def score(self, prefix: str, items: Sequence[tuple[str, str]]) -> list[float]:
        """log P(target | prefix + context) for each (context, target), natural log."""
        ...


def default_cache_dir() -> Path:
    """``$SIFTOM_CACHE_DIR`` or ``~/.cache/siftom`` (:func:`siftom.backends.config.cache_root`)."""
    from siftom.backends.config import cache_root

    return cache_root()


class _SqliteMap:
    """A thread- and process-safe key -> value table in one SQLite file (the caches below)."""

    TABLE = ""
    COLUMNS = ""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(path), check_same_thread=False, timeout=30)
        with self._lock, self._db:
            self._db.execute(f"CREATE TABLE IF NOT EXISTS {self.TABLE} ({self.COLUMNS})")

    def __len__(self) -> int:
        with self._lock:
            return int(self._db.execute(f"SELECT COUNT(*) FROM {self.TABLE}").fetchone()[0])

    def close(self) -> None:
        """Close the database."""
        with self._lock:
            self._db.close()


class ScoreCache(_SqliteMap):
    """A persistent map from (model, prompt, target) to a log-probability, in SQLite.

    Keys are SHA-256 hashes, so prompts of any length are cheap to store and look up.
    Safe to share between threads of one process and between processes.
    """

    TABLE, COLUMNS = "scores", "key TEXT PRIMARY KEY, logp REAL"

    @staticmethod
    def key(model: str, prompt: str, target: str) -> str:
        """Hash of the three strings (NUL-separated, so boundaries are unambiguous)."""
        return hashlib.sha256("\0".join((model, prompt, target)).encode()).hexdigest()

    def get_many(self, keys: Sequence[str]) -> dict[str, float]:
        """Cached values for the keys that are present."""
        out: dict[str, float] = {}
        with self._lock:
            for start in range(0, len(keys), 500):
                chunk = list(keys[start : start + 500])
                q = f"SELECT key, logp FROM scores WHERE key IN ({','.join('?' * len(chunk))})"
                out.update(dict(self._db.execute(q, chunk).fetchall()))
        return out

    def put_many(self, values: dict[str, float]) -> None:
        """Store values (replacing any present)."""
        with self._lock, self._db:
            self._db.executemany("INSERT OR REPLACE INTO scores VALUES (?, ?)", list(values.items()))


class ResponseCache(_SqliteMap):
    """A persistent map from a request (hashed) to the endpoint's JSON answer, in SQLite."""

    TABLE, COLUMNS = "responses", "key TEXT PRIMARY KEY, body TEXT"

    def get(self, key: str) -> str | None:
        """The stored answer, or None."""
        with self._lock:
            row = self._db.execute("SELECT body FROM responses WHERE key = ?", (key,)).fetchone()
        return None if row is None else str(row[0])

    def put(self, key: str, body: str) -> None:
        """Store an answer (replacing any present)."""
        with self._lock, self._db:
            self._db.execute("INSERT OR REPLACE INTO responses VALUES (?, ?)", (key, body))
