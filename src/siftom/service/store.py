"""Durable session storage: one SQLite file in the service's data directory.

Every change is committed before the HTTP response is sent, so a service killed at any moment
and started again on the same data directory continues every session where it stopped
(``PRAGMA journal_mode=WAL``; ``synchronous=NORMAL`` survives a killed process, which is the
failure this guards against; set ``synchronous=FULL`` for power loss at some speed cost).

Tables: ``sessions`` (the world as the client sent it, options, times, the last instruction's
answer) and ``actions`` (one row per observed action in siftom's canonical form, with the
source it came from: ``actions`` for the API, room for others such as ``perceive``).
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    id TEXT PRIMARY KEY,
    created REAL NOT NULL,
    updated REAL NOT NULL,
    spec TEXT NOT NULL,
    options TEXT NOT NULL,
    last TEXT
);
CREATE TABLE IF NOT EXISTS actions (
    session TEXT NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    seq INTEGER NOT NULL,
    text TEXT NOT NULL,
    source TEXT NOT NULL,
    PRIMARY KEY (session, seq)
);
"""


@dataclass(frozen=True)
class StoredSession:
    """One session row with its actions, as written."""

    id: str
    created: float
    updated: float
    spec: dict[str, Any]
    options: dict[str, Any]
    actions: list[str]
    last: dict[str, Any] | None


class SessionStore:
    """Thread-safe access to the SQLite file (one connection behind a lock)."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.execute("PRAGMA foreign_keys=ON")
        self._db.executescript(SCHEMA)

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def create(self, sid: str, spec: dict[str, Any], options: dict[str, Any]) -> float:
        now = time.time()
        with self._lock:
            self._db.execute("INSERT INTO sessions (id, created, updated, spec, options) VALUES (?, ?, ?, ?, ?)",
                             (sid, now, now, json.dumps(spec, separators=(",", ":")), json.dumps(options)))
        return now

    def append(self, sid: str, first_seq: int, texts: list[str], source: str) -> float:
        """Append actions ``first_seq, first_seq+1, ...`` in one transaction."""
        now = time.time()
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.executemany("INSERT INTO actions (session, seq, text, source) VALUES (?, ?, ?, ?)",
                                     [(sid, first_seq + k, t, source) for k, t in enumerate(texts)])
                self._db.execute("UPDATE sessions SET updated = ? WHERE id = ?", (now, sid))
                self._db.execute("COMMIT")
            except sqlite3.IntegrityError:
                self._db.execute("ROLLBACK")
                gone = self._db.execute("SELECT 1 FROM sessions WHERE id = ?", (sid,)).fetchone() is None
                from siftom.service.problems import ProblemError

                if gone:
                    raise ProblemError(404, "unknown-session", f"session {sid!r} was deleted or expired "
                                       "meanwhile; create a new one with POST /v1/sessions") from None
                raise ProblemError(409, "conflict", f"session {sid!r} was changed by another request at the "
                                   "same time; GET it and send the actions again") from None
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
        return now

    def set_last(self, sid: str, last: dict[str, Any]) -> float:
        now = time.time()
        with self._lock:
            self._db.execute("UPDATE sessions SET last = ?, updated = ? WHERE id = ?", (json.dumps(last), now, sid))
        return now

    def touch(self, sid: str) -> None:
        with self._lock:
            self._db.execute("UPDATE sessions SET updated = ? WHERE id = ?", (time.time(), sid))

    def load(self, sid: str) -> StoredSession | None:
        with self._lock:
            row = self._db.execute("SELECT id, created, updated, spec, options, last FROM sessions WHERE id = ?",
                                   (sid,)).fetchone()
            if row is None:
                return None
            acts = [r[0] for r in self._db.execute("SELECT text FROM actions WHERE session = ? ORDER BY seq", (sid,))]
        return StoredSession(row[0], row[1], row[2], json.loads(row[3]), json.loads(row[4]), acts,
                             json.loads(row[5]) if row[5] else None)

    def delete(self, sid: str) -> bool:
        with self._lock:
            cur = self._db.execute("DELETE FROM sessions WHERE id = ?", (sid,))
        return cur.rowcount > 0

    def count(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0])

    def expire(self, before: float) -> list[str]:
        """Delete sessions not updated since ``before``; return their ids."""
        with self._lock:
            ids = [r[0] for r in self._db.execute("SELECT id FROM sessions WHERE updated < ?", (before,))]
            if ids:
                self._db.execute("DELETE FROM sessions WHERE updated < ?", (before,))
        return ids
