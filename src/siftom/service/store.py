"""Durable session storage: one SQLite file in the service's data directory.

Every change is committed before the HTTP response is sent, so a service killed at any moment
and started again on the same data directory continues every session where it stopped
(``PRAGMA journal_mode=WAL``; ``synchronous=NORMAL`` survives a killed process, which is the
failure this guards against; set ``synchronous=FULL`` for power loss at some speed cost).

Tables: ``sessions`` (the world as the client sent it, options, times, the last instruction's
answer) and ``actions`` (one row per observed action in siftom's canonical form, with the
source it came from: ``actions`` for the API, room for others such as ``perceive``).
``replies`` keeps the first answer to each ``Idempotency-Key`` of a session, written in the
same transaction as the change it answers, so a retry after a lost reply (or a restart) gets
that answer again and changes nothing; ``closed`` remembers the keys of ``DELETE`` requests for
as long as a session may stay idle; ``created`` keeps the first answer to each
``Idempotency-Key`` of a session-creating request (``POST /v1/sessions``, ``/from-scenario``),
claimed in the same transaction as the session it created, for as long too.

**A full disk.** A write the disk (or a quota) refuses raises :class:`DiskFullError` (the service
answers 507). The store keeps ``RESERVE_BYTES`` of room next to its file (``*.reserve``), given
up when a delete finds the disk full, so ``DELETE`` still works and the space of the sessions
deleted is reused by the next ones; the reserve is made again once the disk has room (four
times the reserve free). At start it is made whenever it fits; a disk too full even for that is
logged, and a delete that then finds no room is a 507 saying to free space (not to delete).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import sqlite3
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from siftom.private import FILE_MODE, create_private, private_dir
from siftom.service.diskfull import RESERVE_BYTES, damaged_fix, first_line, is_damaged, schema_clash
from siftom.service.diskfull import SQLITE_FULL as SQLITE_FULL
from siftom.service.diskfull import DiskFullError as DiskFullError
from siftom.service.diskfull import StoreDamagedError as StoreDamagedError
from siftom.service.diskfull import is_disk_full as is_disk_full
from siftom.service.session_records import SessionOptions, SessionReply, SessionSpec

log = logging.getLogger("siftom.service")

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
CREATE TABLE IF NOT EXISTS replies (
    session TEXT NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    key TEXT NOT NULL,
    request TEXT NOT NULL,
    reply TEXT NOT NULL,
    PRIMARY KEY (session, key)
);
CREATE TABLE IF NOT EXISTS closed (
    session TEXT NOT NULL,
    key TEXT NOT NULL,
    at REAL NOT NULL,
    PRIMARY KEY (session, key)
);
CREATE TABLE IF NOT EXISTS created (
    key TEXT PRIMARY KEY,
    request TEXT NOT NULL,
    session TEXT NOT NULL,
    reply TEXT,
    at REAL NOT NULL
);
"""


@dataclass(frozen=True)
class Reply:
    """The first answer to an idempotent request: ``request`` fingerprints what was asked."""

    request: str
    reply: SessionReply


@dataclass(frozen=True)
class Creation:
    """The session a session-creating Idempotency-Key made: its first answer (None while the
    request that made it has not finished)."""

    request: str
    session: str
    reply: SessionReply | None


class KeyTaken(Exception):
    """Another request with this Idempotency-Key created a session first."""


@dataclass(frozen=True)
class StoredSession:
    """One session row with its actions, as written."""

    id: str
    created: float
    updated: float
    spec: SessionSpec
    options: SessionOptions
    actions: list[str]
    last: SessionReply | None


class SessionStore:
    """Thread-safe access to the SQLite file (one connection behind a lock)."""

    def __init__(self, path: Path) -> None:
        private_dir(path.parent)
        create_private(path)  # SQLite gives its -wal and -shm files the database's mode
        self.path = path
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
        try:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute("PRAGMA foreign_keys=ON")
            self._db.executescript(SCHEMA)
            problems = [r[0] for r in self._db.execute("PRAGMA quick_check(3)")]
            if problems != ["ok"]:
                raise sqlite3.DatabaseError(f"database disk image is malformed: {'; '.join(problems)[:300]}")
        except sqlite3.DatabaseError as exc:
            self._db.close()
            if not is_damaged(exc) and not schema_clash(exc):
                raise
            raise StoreDamagedError(f"the session store {path} cannot be read ({first_line(exc)}); "
                                    f"{damaged_fix(path)}") from None
        self.reserve = path.with_name(path.name + ".reserve")
        self._refill_reserve(need=RESERVE_BYTES + RESERVE_BYTES // 4)
        if not self.reserve.exists():
            log.warning("the disk of %s has under %d KiB free: no room is kept for deleting sessions once it is "
                        "full; free space there", path, (RESERVE_BYTES + RESERVE_BYTES // 4) // 1024)

    # ----- a full disk -------------------------------------------------------------------------
    def _refill_reserve(self, need: int = 4 * RESERVE_BYTES) -> None:
        """Make the reserve file when it is missing and the disk has ``need`` bytes free (at start:
        room for it; later: more, so the room deletes freed is used first)."""
        if self.reserve.exists():
            return
        with contextlib.suppress(OSError):
            if shutil.disk_usage(self.reserve.parent).free < need:
                return
        try:
            fd = os.open(self.reserve, os.O_WRONLY | os.O_CREAT | os.O_EXCL, FILE_MODE)
        except OSError:
            return
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(bytes(RESERVE_BYTES))  # real blocks, not a sparse file
        except OSError:
            with contextlib.suppress(OSError):
                self.reserve.unlink()

    def _release_reserve(self) -> bool:
        """Give the reserve's room back to the disk; whether there was one."""
        try:
            self.reserve.unlink()
        except OSError:
            return False
        log.warning("the disk of %s is full: its reserve was given up so sessions can be deleted", self.path)
        return True

    def _checkpoint(self, mode: str = "PASSIVE") -> bool:
        """Copy the write-ahead log into the database (the pages of deleted sessions are reused),
        so the next write starts the log over in the room it has (``TRUNCATE``: and give the log's
        room back to the disk); whether that worked."""
        try:
            busy, _log, _done = self._db.execute(f"PRAGMA wal_checkpoint({mode})").fetchone()
        except sqlite3.Error:
            return False
        return not busy

    def _rollback(self) -> None:
        """Roll back the open transaction, if SQLite has not already (it does after SQLITE_FULL)."""
        if self._db.in_transaction:
            with contextlib.suppress(sqlite3.Error):
                self._db.execute("ROLLBACK")

    @contextlib.contextmanager
    def _full(self) -> Iterator[None]:
        """Turn a full disk into :class:`DiskFullError`, the transaction rolled back."""
        try:
            yield
        except (sqlite3.Error, OSError) as exc:
            if not is_disk_full(exc):
                raise
            self._rollback()
            raise DiskFullError(str(exc)) from exc

    @contextlib.contextmanager
    def _tx(self) -> Iterator[None]:
        """One transaction (the connection is in autocommit mode); call with the lock held."""
        with self._full():
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield
            except BaseException:
                self._rollback()
                raise
            self._db.execute("COMMIT")

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def create(self, sid: str, spec: SessionSpec, options: SessionOptions,
               claim: tuple[str, str] | None = None) -> float:
        """Store a new session; ``claim`` (key, request): the Idempotency-Key that created it,
        recorded in the same transaction (:class:`KeyTaken` when another request claimed it)."""
        with self._lock:
            self._refill_reserve()
            try:
                return self._create(sid, spec, options, claim)
            except DiskFullError:
                if not self._checkpoint():  # the log written over from its start needs no new room
                    raise
                return self._create(sid, spec, options, claim)

    def _create(self, sid: str, spec: SessionSpec, options: SessionOptions, claim: tuple[str, str] | None
                ) -> float:
        now = time.time()
        with self._full():
            self._db.execute("BEGIN IMMEDIATE")
            try:
                if claim is not None:
                    self._db.execute("INSERT INTO created (key, request, session, at) VALUES (?, ?, ?, ?)",
                                     (*claim, sid, now))
                self._db.execute("INSERT INTO sessions (id, created, updated, spec, options) VALUES (?, ?, ?, ?, ?)",
                                 (sid, now, now, json.dumps(spec.model_dump(), separators=(",", ":")),
                                  json.dumps(options.model_dump(mode="json"))))
                self._db.execute("COMMIT")
            except sqlite3.IntegrityError:
                self._rollback()
                raise KeyTaken(claim[0] if claim else sid) from None
            except BaseException:
                self._rollback()
                raise
        return now

    def creation(self, key: str) -> Creation | None:
        """What the session-creating request with this Idempotency-Key made, or None."""
        with self._lock:
            row = self._db.execute("SELECT request, session, reply FROM created WHERE key = ?", (key,)).fetchone()
        return None if row is None else Creation(row[0], row[1], _reply(row[2]))

    def set_creation_reply(self, key: str, answer: SessionReply) -> None:
        """Record the first answer of the request that claimed ``key`` (kept if one is there)."""
        with self._lock, self._full():
            self._db.execute("UPDATE created SET reply = ? WHERE key = ? AND reply IS NULL",
                             (json.dumps(answer.to_json()), key))

    def append(self, sid: str, first_seq: int, texts: list[str], source: str,
               reply: tuple[str, str, SessionReply] | None = None) -> float:
        """Append actions ``first_seq, first_seq+1, ...`` in one transaction; ``reply`` (key,
        request, answer): the idempotency record written in the same transaction."""
        now = time.time()
        with self._lock, self._full():
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.executemany("INSERT INTO actions (session, seq, text, source) VALUES (?, ?, ?, ?)",
                                     [(sid, first_seq + k, t, source) for k, t in enumerate(texts)])
                if reply is not None:
                    self._put_reply(sid, *reply)
                self._db.execute("UPDATE sessions SET updated = ? WHERE id = ?", (now, sid))
                self._db.execute("COMMIT")
            except sqlite3.IntegrityError:
                self._rollback()
                gone = self._db.execute("SELECT 1 FROM sessions WHERE id = ?", (sid,)).fetchone() is None
                from siftom.service.problems import ProblemError

                if gone:
                    raise ProblemError(404, "unknown-session", f"session {sid!r} was deleted or expired "
                                       "meanwhile; create a new one with POST /v1/sessions") from None
                raise ProblemError(409, "conflict", f"session {sid!r} was changed by another request at the "
                                   "same time; GET it and send the actions again") from None
            except BaseException:
                self._rollback()
                raise
        return now

    def set_last(self, sid: str, last: SessionReply, reply: tuple[str, str] | None = None) -> float:
        """Store the last instruction's answer; ``reply`` (key, request): it is also that key's answer."""
        now = time.time()
        with self._lock, self._tx():  # one transaction
            self._db.execute("UPDATE sessions SET last = ?, updated = ? WHERE id = ?", (json.dumps(last.to_json()), now, sid))
            if reply is not None:
                self._put_reply(sid, *reply, last)
        return now

    def _put_reply(self, sid: str, key: str, request: str, answer: SessionReply) -> None:
        self._db.execute("INSERT OR REPLACE INTO replies (session, key, request, reply) VALUES (?, ?, ?, ?)",
                         (sid, key, request, json.dumps(answer.to_json())))

    def put_reply(self, sid: str, key: str, request: str, answer: SessionReply) -> None:
        """Record (or complete) the first answer to ``key``."""
        with self._lock, self._tx():
            self._put_reply(sid, key, request, answer)

    def reply(self, sid: str, key: str) -> Reply | None:
        """The first answer given to ``key`` in session ``sid``, or None."""
        with self._lock:
            row = self._db.execute("SELECT request, reply FROM replies WHERE session = ? AND key = ?",
                                   (sid, key)).fetchone()
        return None if row is None else Reply(row[0], SessionReply(json.loads(row[1])))

    def closed_by(self, sid: str, key: str) -> bool:
        """Whether session ``sid`` was deleted by a request with this Idempotency-Key."""
        with self._lock:
            return self._db.execute("SELECT 1 FROM closed WHERE session = ? AND key = ?",
                                    (sid, key)).fetchone() is not None

    def touch(self, sid: str) -> None:
        """Mark ``sid`` used now (nothing when the disk is full: it only delays the expiry)."""
        with self._lock, contextlib.suppress(DiskFullError), self._full():
            self._db.execute("UPDATE sessions SET updated = ? WHERE id = ?", (time.time(), sid))

    def load(self, sid: str) -> StoredSession | None:
        with self._lock:
            row = self._db.execute("SELECT id, created, updated, spec, options, last FROM sessions WHERE id = ?",
                                   (sid,)).fetchone()
            if row is None:
                return None
            acts = [r[0] for r in self._db.execute("SELECT text FROM actions WHERE session = ? ORDER BY seq", (sid,))]
        return StoredSession(row[0], row[1], row[2], SessionSpec.model_validate_json(row[3]),
                             SessionOptions.model_validate_json(row[4]), acts, _reply(row[5]))

    def delete(self, sid: str, key: str | None = None) -> bool:
        """Delete a session; with ``key``, remember that this key closed it (one transaction). On
        a full disk the reserve is given up and the delete tried again, so it still succeeds."""
        with self._lock:
            try:
                return self._delete(sid, key)
            except DiskFullError:
                if not self._release_reserve() and not self._checkpoint("TRUNCATE"):
                    raise
            gone = self._delete(sid, key)
            self._checkpoint()
            return gone

    def _delete(self, sid: str, key: str | None) -> bool:
        with self._tx():
            cur = self._db.execute("DELETE FROM sessions WHERE id = ?", (sid,))
            if key is not None and cur.rowcount > 0:
                self._db.execute("INSERT OR REPLACE INTO closed (session, key, at) VALUES (?, ?, ?)",
                                 (sid, key, time.time()))
        return cur.rowcount > 0

    def count(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0])

    def expire(self, before: float) -> list[str]:
        """Delete sessions not updated since ``before``; return their ids."""
        with self._lock:
            ids = [r[0] for r in self._db.execute("SELECT id FROM sessions WHERE updated < ?", (before,))]
            try:
                self._expire(before, bool(ids))
            except DiskFullError:
                if not self._release_reserve():
                    raise
                self._expire(before, bool(ids))
        return ids

    def _expire(self, before: float, sessions: bool) -> None:
        with self._tx():
            if sessions:
                self._db.execute("DELETE FROM sessions WHERE updated < ?", (before,))
            self._db.execute("DELETE FROM closed WHERE at < ?", (before,))
            self._db.execute("DELETE FROM created WHERE at < ?", (before,))


def _reply(text: str | None) -> SessionReply | None:
    return SessionReply(json.loads(text)) if text else None
