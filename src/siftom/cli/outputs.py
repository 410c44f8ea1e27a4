"""Where a command writes its results: the folder is created, committed results are kept.

A command that writes a result file (``--out FILE``) creates the file's folder, and refuses to
overwrite a file that the repository tracks (the committed results under ``results/``) unless
``--force`` is given: re-running a page's command from the root of a clone must not replace the
numbers the pages quote.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

import click


def force_option(f: Any) -> Any:
    return click.option("--force", is_flag=True,
                        help="overwrite --out even when it is a committed result file (tracked by git)")(f)


def is_committed(path: Path) -> bool:
    """Whether ``path`` exists and is tracked by the git repository it lies in (False without git)."""
    if not path.is_file() or shutil.which("git") is None:
        return False
    try:
        res = subprocess.run(["git", "ls-files", "--error-unmatch", "--", path.name], cwd=path.parent,
                             capture_output=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return False
    return res.returncode == 0


def prepare_output(out: str | Path, force: bool, option: str = "--out") -> Path:
    """The path to write: its folder created; a committed file is refused unless ``force``."""
    p = Path(out)
    if p.is_dir():
        raise click.BadParameter(f"{p} is a folder; give a file name", param_hint=f"'{option}'")
    if not force and is_committed(p):
        raise click.BadParameter(f"{p} is a committed result (tracked by git); write elsewhere, "
                                 "or add --force to overwrite it", param_hint=f"'{option}'")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise click.BadParameter(f"cannot create the folder {p.parent}: {e.strerror}", param_hint=f"'{option}'") from e
    return p
