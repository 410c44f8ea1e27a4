"""Every block marked ``<!-- run -->`` in docs/tutorials/*.md and README.md runs, in order, in a fresh folder.

``python`` blocks run in one interpreter per page (later blocks see earlier files); ``console``
blocks run each ``$ `` line in bash with this interpreter's ``siftom`` and ``python`` first on
the PATH; a line ending in a backslash continues on the next. ``SRC`` in a command stands for
the repository root. README.md's blocks run in a folder that sees the repository's docs/ and data/.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
BLOCK = re.compile(r"<!-- run -->\s*\n```(python|console)\n(.*?)\n```", re.DOTALL)


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of each block marked to run, in page order."""
    return [(m.group(1), m.group(2)) for m in BLOCK.finditer(text)]


def console_commands(code: str) -> list[str]:
    """The ``$ `` commands of a console block, continuation lines joined."""
    out: list[str] = []
    for line in code.splitlines():
        if out and out[-1].endswith("\\"):
            out[-1] = out[-1][:-1] + " " + line.strip()
        elif line.startswith("$ "):
            out.append(line[2:])
    return out


def _env(bindir: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["MPLBACKEND"] = "Agg"
    return env


def _bindir(tmp: Path) -> Path:
    """A folder with ``python`` and ``siftom`` for this interpreter and these sources."""
    b = tmp / "_bin"
    b.mkdir()
    (b / "python").symlink_to(sys.executable)
    (b / "siftom").write_text(f"#!/bin/sh\nexec {sys.executable} -m siftom.cli \"$@\"\n")
    (b / "siftom").chmod(0o755)
    return b


# Tutorials that run end to end offline; a tutorial around servers a person uses in a browser
# (collecting recordings, annotating) is exercised by its feature's own tests instead.
OFFLINE = ("first-inference", "your-robot", "reproduce-paper", "own-recordings")


def test_every_offline_tutorial_has_runnable_blocks() -> None:
    names = {p.stem for p in TUTORIALS}
    assert set(OFFLINE) <= names, f"missing tutorials: {set(OFFLINE) - names}"
    for page in TUTORIALS:
        if page.stem in OFFLINE:
            assert runnable_blocks(page.read_text(encoding="utf-8")), f"{page.name} has no <!-- run --> block"


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
@pytest.mark.parametrize("page", [*TUTORIALS, ROOT / "README.md"], ids=[*(p.stem for p in TUTORIALS), "README"])
def test_tutorial_blocks_run(page: Path, tmp_path: Path) -> None:
    work = tmp_path / "work"
    work.mkdir()
    if page.name == "README.md":
        for name in ("docs", "data"):
            (work / name).symlink_to(ROOT / name)
    env = _env(_bindir(tmp_path))
    for k, (lang, code) in enumerate(runnable_blocks(page.read_text(encoding="utf-8"))):
        if lang == "python":
            res = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True,
                                 text=True, timeout=300)
            assert res.returncode == 0, f"{page.name} block {k} (python) failed:\n{code}\n{res.stderr[-2000:]}"
            continue
        for line in console_commands(code):
            cmd = line.replace("SRC", str(ROOT))
            res = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True, timeout=300)
            assert res.returncode == 0, f"{page.name} block {k}: `{cmd}` failed:\n{res.stderr[-2000:]}"
