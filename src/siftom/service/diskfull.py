"""A full disk, recognised: the session store raises it, the HTTP layer answers it with 507."""

from __future__ import annotations

import errno
import sqlite3

SQLITE_FULL = 13
RESERVE_BYTES = 1024 * 1024  # kept free for deletes on a full disk: a delete writes a few pages to the write-ahead log


class DiskFullError(Exception):
    """A write was refused because the disk (or the user's quota) is full."""


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` says the disk or quota is full (OSError ENOSPC/EDQUOT, SQLite's SQLITE_FULL)."""
    if isinstance(exc, OSError):
        return exc.errno in (errno.ENOSPC, errno.EDQUOT)
    if isinstance(exc, sqlite3.Error):
        return (getattr(exc, "sqlite_errorcode", None) == SQLITE_FULL
                or "database or disk is full" in str(exc))
    return False
