"""A full disk and a damaged session store, recognised: the session store raises them, the HTTP
layer answers a full disk with 507 and a damaged store with a 500 that says it is the server's."""

from __future__ import annotations

import errno
import sqlite3

from siftom.errors import SiftomError

SQLITE_FULL = 13
SQLITE_CORRUPT, SQLITE_NOTADB = 11, 26
RESERVE_BYTES = 1024 * 1024  # kept free for deletes on a full disk: a delete writes a few pages to the write-ahead log


class DiskFullError(Exception):
    """A write was refused because the disk (or the user's quota) is full."""


class StoreDamagedError(SiftomError):
    """The session store's file is damaged or is not a session store (at start)."""


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` says the disk or quota is full (OSError ENOSPC/EDQUOT, SQLite's SQLITE_FULL)."""
    if isinstance(exc, OSError):
        return exc.errno in (errno.ENOSPC, errno.EDQUOT)
    if isinstance(exc, sqlite3.Error):
        return (getattr(exc, "sqlite_errorcode", None) == SQLITE_FULL
                or "database or disk is full" in str(exc))
    return False


def is_damaged(exc: BaseException) -> bool:
    """Whether ``exc`` says the SQLite file is damaged (SQLITE_CORRUPT, SQLITE_NOTADB)."""
    if not isinstance(exc, sqlite3.DatabaseError):
        return False
    code = getattr(exc, "sqlite_errorcode", None)
    if code is not None and code & 0xFF in (SQLITE_CORRUPT, SQLITE_NOTADB):
        return True
    text = str(exc).lower()
    return "malformed" in text or "not a database" in text or "corrupt" in text


def damaged_fix(path: object) -> str:
    """What the operator does about a damaged store file at ``path``."""
    return (f"move {path} (and its -wal and -shm files) aside, e.g. to {path}.damaged, and start the server "
            "again with an empty store (the sessions in it are lost; `sqlite3 FILE .recover` may save some), or "
            "start it with another --data-dir")


def first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0][:300]


def schema_clash(exc: BaseException) -> bool:
    """A file that is a database but not a session store (a table of that name with other columns)."""
    return isinstance(exc, sqlite3.OperationalError) and ("no such column" in str(exc) or "has no column" in str(exc))
