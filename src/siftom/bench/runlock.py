"""One writer per results folder, and runs that stop cleanly on SIGINT / SIGTERM.

* :class:`RunLock` holds ``FOLDER/.siftom.lock``: an exclusive ``flock`` on a file that names
  the owner (pid, host, command, start time). A second run on the folder is refused with a
  message naming the owner. The kernel drops the ``flock`` when its owner dies, however it
  dies, so a lock left behind by a dead process is taken over without asking anybody.
  Where the file system has no ``flock`` (some network mounts), the owner's pid and host decide:
  a live pid on this host, or any other host, keeps the folder; a dead local pid is stale.
* :func:`stop_on_signals` turns SIGTERM (and SIGINT) into :class:`RunInterrupted`, an exception
  that unwinds the run like Ctrl-C does, so the ``finally`` blocks stop the workers and close
  the files, and the CLI exits with ``128 + signal``.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from siftom.errors import DatasetError

LOCK = ".siftom.lock"

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]


class RunLockedError(DatasetError):
    """Another live siftom process writes into the results folder."""


class LockFileError(DatasetError):
    """The folder or its lock file cannot be used (a directory, unreadable, not a siftom lock)."""


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped by a signal; ``signum`` is SIGINT or SIGTERM."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@dataclass(frozen=True)
class LockOwner:
    """Who holds a results folder, as its lock file says: process id, host, start time and command
    line (None where the file does not say)."""

    pid: int | None = None
    host: str | None = None
    started: str | None = None
    command: str | None = None

    @classmethod
    def here(cls) -> LockOwner:
        """This process, now."""
        return cls(os.getpid(), socket.gethostname(), time.strftime("%Y-%m-%dT%H:%M:%S"), " ".join(sys.argv)[:300])

    def is_me(self) -> bool:
        """Whether the lock file names this process on this host."""
        return self.pid == os.getpid() and self.host == socket.gethostname()

    def to_json(self) -> dict[str, Any]:
        """The lock file's content."""
        return {"pid": self.pid, "host": self.host, "started": self.started, "command": self.command}


def read_owner(folder: str | Path) -> LockOwner | None:
    """The lock file's owner record, or None when there is none (or it is unreadable or empty)."""
    try:
        d = json.loads((Path(folder) / LOCK).read_text(encoding="utf-8"))
    except (OSError, ValueError):  # ValueError: JSONDecodeError, UnicodeDecodeError
        return None
    if not isinstance(d, dict) or not d:
        return None
    return LockOwner(d.get("pid"), d.get("host"), d.get("started"), d.get("command", "?"))


def _check_lock_text(path: Path) -> None:
    """LockFileError when the file at ``path`` is not text siftom could have written (UTF-8)."""
    try:
        path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        return
    except UnicodeDecodeError:
        raise LockFileError(f"{path} is not a siftom lock file (not UTF-8 text); if no siftom run uses "
                            f"{path.parent}, delete {path} and run again") from None
    except OSError as exc:
        raise LockFileError(f"cannot read the lock file {path} ({exc.strerror or type(exc).__name__}); "
                            "make it readable, or delete it if no siftom run uses the folder") from None


def _open_error(path: Path, exc: OSError) -> LockFileError:
    """A one-line error for a lock path that cannot be opened."""
    if isinstance(exc, IsADirectoryError) or path.is_dir():
        return LockFileError(f"the lock file {path} is a directory; remove it (siftom keeps its lock file "
                             "there) and run again")
    return LockFileError(f"cannot open the lock file {path} ({exc.strerror or type(exc).__name__}); make "
                         f"{path.parent} writable, or give another folder")


def _describe(owner: LockOwner | None) -> str:
    if owner is None:
        return "another process"
    return f"siftom pid {owner.pid} on host {owner.host!r} since {owner.started} ({owner.command})"


# (resolved folder, thread) -> (fd, depth): re-entrant within a thread; another thread of the
# same process opens its own descriptor, and flock refuses it like another process
_HELD: dict[tuple[str, int], tuple[int, int]] = {}
_HELD_MUTEX = threading.Lock()


class RunLock:
    """Exclusive ownership of a results folder, re-entrant within one thread.

    Use as a context manager; ``took_over`` holds the record of a stale lock that was taken over.
    ``fix`` ends the refusal's message: what the user can do instead.

    Raises:
        RunLockedError: another live process owns the folder.
    """

    def __init__(self, folder: str | Path, fix: str = "wait for it to finish (or stop it), or give another --out folder"
                 ) -> None:
        self.folder = Path(folder)
        self.fix = fix
        self.path = self.folder / LOCK
        self.took_over: LockOwner | None = None
        self._key: tuple[str, int] = ("", 0)

    def __enter__(self) -> RunLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the folder, or raise RunLockedError naming its owner."""
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise LockFileError(f"{self.folder} is a file, not a folder; give a folder (or a new name)") from None
        except OSError as exc:
            raise LockFileError(f"cannot create the folder {self.folder} "
                                f"({exc.strerror or type(exc).__name__}); give a folder you can write to") from None
        self._key = (str(self.folder.resolve()), threading.get_ident())
        with _HELD_MUTEX:
            if self._key in _HELD:
                fd, depth = _HELD[self._key]
                _HELD[self._key] = (fd, depth + 1)
                return
            fd = self._take()
            _HELD[self._key] = (fd, 1)

    def _take(self) -> int:
        for _ in range(20):  # retried only when a releasing owner unlinks the file under us
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
            except OSError as exc:
                raise _open_error(self.path, exc) from None
            try:
                if not self._flock(fd):
                    raise RunLockedError(
                        f"{self.folder} is being written by {_describe(read_owner(self.folder))}; {self.fix}"
                    )
                try:
                    same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
                except FileNotFoundError:
                    same = False
                if not same:
                    os.close(fd)
                    continue
                _check_lock_text(self.path)
                old = read_owner(self.folder)
                if old is not None and not old.is_me():
                    self.took_over = old
                    print(f"note: taking over the stale lock of {_describe(old)} on {self.folder}", file=sys.stderr)
                data = (json.dumps(LockOwner.here().to_json()) + "\n").encode()
                os.ftruncate(fd, 0)
                os.pwrite(fd, data, 0)
                os.fsync(fd)
                return fd
            except BaseException:
                os.close(fd)
                raise
        raise RunLockedError(f"could not lock {self.path}: it keeps being replaced; is another siftom starting?")

    def _flock(self, fd: int) -> bool:
        """True when this process now owns the lock."""
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return True
            except BlockingIOError:
                return False
            except OSError as exc:
                if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                    raise
        # no flock here: decide by the recorded owner
        owner = read_owner(self.folder)
        if owner is None or owner.is_me():
            return True
        if owner.host != socket.gethostname():
            return False
        return not _pid_alive(int(owner.pid or 0))

    def release(self) -> None:
        """Give the folder back (the outermost release removes the lock file)."""
        with _HELD_MUTEX:
            if self._key not in _HELD:
                return
            fd, depth = _HELD[self._key]
            if depth > 1:
                _HELD[self._key] = (fd, depth - 1)
                return
            del _HELD[self._key]
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)  # still holding the flock, so no one took it meanwhile
            os.close(fd)


_RECEIVED = [0]


def interrupting_signal(exc: BaseException) -> int:
    """The signal behind a KeyboardInterrupt: its own, or the last one caught (some libraries,
    Ray among them, re-raise a plain KeyboardInterrupt from inside a blocking call)."""
    return getattr(exc, "signum", 0) or _RECEIVED[0] or signal.SIGINT


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Raise RunInterrupted in the main thread on SIGINT or SIGTERM; restore the handlers after.

    A second signal while the run is being stopped is ignored, so the cleanup (stopping the
    workers, closing the files) finishes. Outside the main thread this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    stopping = False

    def handler(signum: int, frame: Any) -> None:
        nonlocal stopping
        _RECEIVED[0] = signum
        if stopping:
            return
        stopping = True
        raise RunInterrupted(signum)

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def ignore_signals_in_worker() -> None:
    """Worker processes leave SIGINT to the parent, which stops them (terminal Ctrl-C hits all)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
