"""Files only their owner can read: study data (voices, consent, answers) and the service's
sessions are written 0600 in 0700 folders.

* :func:`private_umask`: the servers (``siftom serve``, ``collect``, ``annotate``) run under
  umask 077, so whatever they or a library they call create is private.
* The writers of the private files use :func:`private_dir`, :func:`append_private`,
  :func:`write_private_text` and :func:`make_private` too, so the modes hold for a program
  that calls the library under any umask.
"""

from __future__ import annotations

import contextlib
import os
import threading
from pathlib import Path
from typing import TextIO

FILE_MODE = 0o600
DIR_MODE = 0o700


def private_umask() -> int:
    """Make every file and folder this process creates from now on private; the old umask."""
    return os.umask(0o077)


def private_dir(path: str | Path) -> Path:
    """``path`` and its missing parents created 0700 (an existing folder is left as it is)."""
    p = Path(path)
    missing = []
    q = p
    while not q.exists():
        missing.append(q)
        if q.parent == q:
            break
        q = q.parent
    for d in reversed(missing):
        with contextlib.suppress(FileExistsError):
            d.mkdir(mode=DIR_MODE)
            os.chmod(d, DIR_MODE)  # mkdir's mode goes through the umask
    return p


def make_private(path: str | Path) -> None:
    """chmod 0600 an existing file (nothing when it does not exist)."""
    with contextlib.suppress(FileNotFoundError):
        os.chmod(path, FILE_MODE)


def create_private(path: str | Path) -> None:
    """Create ``path`` empty and 0600 unless it exists; an existing one is made 0600."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, FILE_MODE)
    os.close(fd)
    make_private(path)


def append_private(path: str | Path) -> TextIO:
    """``open(path, "a")`` for UTF-8 text lines, the file created 0600."""
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, FILE_MODE)
    with contextlib.suppress(OSError):
        os.fchmod(fd, FILE_MODE)
    return os.fdopen(fd, "a", encoding="utf-8")


def write_private_text(path: str | Path, text: str) -> None:
    """Replace ``path`` with ``text`` atomically (a temporary file renamed over it), 0600."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, FILE_MODE)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.chmod(tmp, FILE_MODE)
    os.replace(tmp, p)
