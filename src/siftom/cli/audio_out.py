"""What the commands that write audio share: the SNRs they take and one-line write errors."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click

from siftom.speech.noise import SNR_RANGE_DB

SNR_MIN_DB, SNR_MAX_DB = SNR_RANGE_DB  # the SNRs a command takes (beyond: silence or noise alone)
WRITE_FIX = "a path in a folder you can write to, on a disk with free space"
FOLDER_FIX = "make the folder writable and free disk space, then run the command again"


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return (text.splitlines()[0] if text else type(exc).__name__)[:200]


def _special(target: str | Path) -> bool:
    """Whether ``target`` exists and is neither a regular file nor a folder (a device, a pipe, a socket)."""
    import stat

    try:
        mode = Path(target).stat().st_mode
    except OSError:
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


@contextmanager
def writing_audio(target: str | Path, what: str = "the WAV file",
                  fix: str = f"give {WRITE_FIX}") -> Iterator[None]:
    """A failure to write audio under ``target`` (a full disk, a device, a read-only folder)
    becomes a one-line click error naming the path and ``fix``, not a traceback."""
    import soundfile as sf

    try:
        yield
    except (OSError, sf.SoundFileError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else _first_line(exc)
        if _special(target):  # a device such as /dev/full: libsndfile says only "System error"
            reason = "it is a device or other special file, not a regular file"
        raise click.ClickException(f"cannot write {what} {str(target)!r} ({reason}); {fix}") from None
