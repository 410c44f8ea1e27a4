"""Every code block of docs/tutorials/*.md and README.md runs in a test, in page order.

A block is marked on the line above it:

* ``<!-- run -->``: ``python`` blocks run in one interpreter per page (later blocks see earlier
  files); ``console`` blocks run each ``$ `` line in bash (a line ending in a backslash continues
  on the next); ``bash`` blocks run whole, as one script. ``siftom`` and ``python`` are this
  interpreter's. The pages speak from the root of a clone, so each runs in a fresh folder that
  sees the clone's docs/ and data/.
* ``<!-- run: serve -->``: the same, with ``siftom serve`` listening where the block says
  (``localhost:8000``) while it runs.
* ``<!-- run: dry -->``: commands a test cannot wait for (hours of work, or a person at a
  browser page): each ``siftom`` line is parsed by the CLI (the command and every option must
  exist) without running; each of them runs small in a ``run`` block of the same page or README.
* ``<!-- run by tests/NAME.py -->``: set-up commands (``make``, ``pip install``) that the named
  test runs or reads.

A fenced block with no commands (a diagram) is ``text``.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
PAGES = [*TUTORIALS, ROOT / "README.md"]
FENCE = re.compile(r"^```(\w*)\n(.*?)\n```$", re.DOTALL | re.MULTILINE)
MARK = re.compile(r"<!-- run(?:: (serve|dry)| by (tests/\S+\.py))? -->\s*$")
RUNS = ("python", "console", "bash")


def page_blocks(text: str) -> list[tuple[str, str, str]]:
    """(language, how, code) of every fenced block, in page order: ``how`` is ``run``, ``serve``,
    ``dry``, the test that runs it (``tests/NAME.py``) or ``""`` for an unmarked block."""
    out = []
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        mark = MARK.search(before)
        how = "" if mark is None else (mark.group(1) or mark.group(2) or "run")
        out.append((m.group(1), how, m.group(2)))
    return out


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of each block marked ``run``, in page order."""
    return [(lang, code) for lang, how, code in page_blocks(text) if how == "run"]


def console_commands(code: str) -> list[str]:
    """The ``$ `` commands of a console block, continuation lines joined."""
    out: list[str] = []
    for line in code.splitlines():
        if out and out[-1].endswith("\\"):
            out[-1] = out[-1][:-1] + " " + line.strip()
        elif line.startswith("$ "):
            out.append(line[2:])
    return out


def script_commands(code: str) -> list[str]:
    """The commands of a bash block (or a console block's ``$ `` lines), continuations joined."""
    if any(ln.startswith("$ ") for ln in code.splitlines()):
        return console_commands(code)
    out: list[str] = []
    for line in code.splitlines():
        if out and out[-1].endswith("\\"):
            out[-1] = out[-1][:-1] + " " + line.strip()
        elif line.strip() and not line.lstrip().startswith("#"):
            out.append(line.strip())
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


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Server:
    """``siftom serve`` on a free port for a ``run: serve`` block."""

    def __init__(self, work: Path, env: dict[str, str]) -> None:
        self.port = _free_port()
        self.proc = subprocess.Popen([sys.executable, "-m", "siftom.cli", "serve", "--port", str(self.port)],
                                     cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        while True:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.port}/healthz", timeout=2).read()
                return
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise AssertionError("siftom serve did not start") from None
                time.sleep(0.5)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def _parses(line: str) -> None:
    """The ``siftom`` command of ``line`` exists and knows every option it is given (nothing runs)."""
    import click

    from siftom.cli import root

    words = shlex.split(line.split(" #")[0].rstrip(" &"))
    assert words[0] == "siftom", line
    cmd: click.Command = root
    args, path = words[1:], "siftom"
    while isinstance(cmd, click.Group):
        assert args and args[0] in cmd.commands, f"`{line}`: {path} has no command {args[:1]}"
        cmd, path, args = cmd.commands[args[0]], f"{path} {args[0]}", args[1:]
    known = {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
    for a in args:
        if a.startswith("-") and len(a) > 1:
            assert a.split("=")[0] in known, f"`{line}`: {path} has no option {a}"


def test_every_block_runs_or_names_what_runs_it() -> None:
    blocks = [b for page in PAGES for b in page_blocks(page.read_text(encoding="utf-8"))]
    ran = " ".join(code for _l, how, code in blocks if how in ("run", "serve"))
    ran += " siftom serve" if any(how == "serve" for _l, how, _c in blocks) else ""
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        assert "SRC" not in "".join(code for _l, _h, code in page_blocks(text)), \
            f"{page.name}: SRC is no path a reader has; the pages speak from the clone's root"
        for lang, how, code in page_blocks(text):
            where = f"{page.name}: the block starting {code[:60]!r}"
            if lang == "text":
                assert not re.search(r"^\$ ", code, re.MULTILINE), f"{where} holds commands: mark it"
                continue
            assert how, f"{where} is not marked: <!-- run -->, <!-- run: dry --> or <!-- run by tests/NAME.py -->"
            if how.startswith("tests/"):
                assert (ROOT / how).is_file(), f"{where}: {how} does not exist"
                continue
            assert lang in RUNS, f"{where}: a {lang!r} block cannot run"
            if how == "dry":
                for line in script_commands(code):
                    if line.startswith("siftom "):
                        _parses(line)
                        name = " ".join(line.split()[:2])
                        assert name in ran, f"{where}: `{name}` runs small in no block that runs"


# Tutorials that run end to end offline; a tutorial around servers a person uses in a browser
# (collecting recordings, annotating) runs its "without participants" script instead.
OFFLINE = ("first-inference", "your-robot", "reproduce-paper", "own-recordings", "own-participants")


def test_every_offline_tutorial_has_runnable_blocks() -> None:
    names = {p.stem for p in TUTORIALS}
    assert set(OFFLINE) <= names, f"missing tutorials: {set(OFFLINE) - names}"
    for page in TUTORIALS:
        if page.stem in OFFLINE:
            assert runnable_blocks(page.read_text(encoding="utf-8")), f"{page.name} has no <!-- run --> block"


def _run_block(page: Path, k: int, lang: str, code: str, work: Path, env: dict[str, str]) -> None:
    if lang == "python":
        res = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True,
                             text=True, timeout=300)
        assert res.returncode == 0, f"{page.name} block {k} (python) failed:\n{code}\n{res.stderr[-2000:]}"
        return
    if lang == "bash":
        res = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=work, env=env, capture_output=True,
                             text=True, timeout=600)
        assert res.returncode == 0, f"{page.name} block {k} (bash) failed:\n{res.stdout[-1500:]}\n{res.stderr[-2000:]}"
        return
    for cmd in console_commands(code):
        res = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, f"{page.name} block {k}: `{cmd}` failed:\n{res.stderr[-2000:]}"


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
@pytest.mark.parametrize("page", PAGES, ids=[p.stem if p.name != "README.md" else "README" for p in PAGES])
def test_tutorial_blocks_run(page: Path, tmp_path: Path) -> None:
    work = tmp_path / "work"
    work.mkdir()
    for name in ("docs", "data"):  # the pages speak from the root of a clone
        (work / name).symlink_to(ROOT / name)
    env = _env(_bindir(tmp_path))
    for k, (lang, how, code) in enumerate(page_blocks(page.read_text(encoding="utf-8"))):
        if how == "run":
            _run_block(page, k, lang, code, work, env)
        elif how == "serve":
            pytest.importorskip("fastapi", reason="siftom serve needs the serve extra")
            server = _Server(work, env)
            try:
                _run_block(page, k, lang, code.replace("localhost:8000", f"localhost:{server.port}"), work, env)
            finally:
                server.stop()
