"""Every code block of README.md and docs/ runs in a test, in page order, and what a page says it
prints is what it prints (the convention: tests/support/page_outputs.py).

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
* ``<!-- run: slow -->``, ``<!-- run: serve slow -->``: a ``run`` (``serve``) block that takes
  long (audio, Whisper, a dataset): it runs in the slow suite (``make test-slow``), with the whole
  page.
* ``<!-- not run: REASON -->``: a block no test can run (a file format, another program's
  configuration, hardware or a service the user brings); it quotes no output.
* ``<!-- output -->``: what the block before it prints (checked).

A ``run`` mark may end in `` tol=X``: the tolerance of the numbers the block's outputs state. A
block that does not run states no output (it says how to produce one instead). A fenced block
with no commands (a diagram) is ``text``.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import pytest

from support.page_outputs import (
    Expected,
    console_expectations,
    mismatch,
    printed_by_line,
    python_expectations,
    run_python_source,
)

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
PAGES = [*TUTORIALS, ROOT / "README.md",
         *sorted(p for p in (ROOT / "docs").rglob("*.md") if p.parent.name != "tutorials")]
FENCE = re.compile(r"^```(\w*)\n(.*?)\n```$", re.DOTALL | re.MULTILINE)
MARK = re.compile(r"<!-- (?:run(?:: (serve slow|serve|dry|slow))?(?: tol=([0-9.]+))?|run by (tests/\S+\.py)|not run: (.+?)"
                  r"|(output)) -->\s*$")
RUNS = ("python", "console", "bash", "sh")


@dataclass(frozen=True)
class Block:
    lang: str
    how: str  # run, serve, dry, slow, tests/NAME.py, not run, output or "" (unmarked)
    code: str
    line: int  # the page line of the block's first code line
    tol: float | None = None


def blocks_of(text: str) -> list[Block]:
    """Every fenced block of a page, in page order, with its mark."""
    out = []
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        mark = MARK.search(before)
        how, tol = "", None
        if mark is not None:
            how = (mark.group(1) or mark.group(3) or ("not run" if mark.group(4) else None)
                   or mark.group(5) or "run")
            tol = float(mark.group(2)) if mark.group(2) else None
        out.append(Block(m.group(1), how, m.group(2), text[:m.start(2)].count("\n") + 1, tol))
    return out


def page_blocks(text: str) -> list[tuple[str, str, str]]:
    """(language, how, code) of every fenced block, in page order: ``how`` is ``run``, ``serve``,
    ``dry``, ``slow``, the test that runs it (``tests/NAME.py``), ``not run``, ``output`` or ``""``
    for an unmarked block."""
    return [(b.lang, b.how, b.code) for b in blocks_of(text)]


def _name(page: Path) -> str:
    return str(page.relative_to(ROOT))


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of each block marked ``run``, in page order."""
    return [(lang, code) for lang, how, code in page_blocks(text) if how in ("run", "slow")]


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
    ran = " ".join(code for _l, how, code in blocks if how in ("run", "serve", "slow", "serve slow"))
    ran += " siftom serve" if any(how.startswith("serve") for _l, how, _c in blocks) else ""
    wrong: list[str] = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        assert "SRC" not in "".join(code for _l, _h, code in page_blocks(text)), \
            f"{page.name}: SRC is no path a reader has; the pages speak from the clone's root"
        for b in blocks_of(text):
            where = f"{_name(page)}:{b.line}: the block starting {b.code[:60]!r}"
            how = b.how
            if b.lang == "text" and how != "output":
                if re.search(r"^\$ ", b.code, re.MULTILINE):
                    wrong.append(f"{where} holds commands: mark it")
                continue
            if not how:
                wrong.append(f"{where} is not marked (the marks: this module's docstring)")
                continue
            if how.startswith("tests/"):
                if not (ROOT / how).is_file():
                    wrong.append(f"{where}: {how} does not exist")
                continue
            if how == "output":
                continue
            if how == "not run":
                if re.search(r"^\$ .*\n(?!\$ )\S", b.code, re.MULTILINE) or "# ->" in b.code:
                    wrong.append(f"{where} does not run, so it quotes no output: say how to produce it")
                continue
            if b.lang not in RUNS:
                wrong.append(f"{where}: a {b.lang!r} block cannot run (mark it <!-- not run: REASON -->)")
                continue
            if how == "dry":
                if "# ->" in b.code:
                    wrong.append(f"{where} does not run, so it quotes no output: say how to produce it")
                if b.lang == "console" and any(e is not None for _c, e in console_expectations(b.code, where, b.line, None)):
                    wrong.append(f"{where} does not run, so it quotes no output: say how to produce it")
                for line in script_commands(b.code):
                    if line.startswith("siftom "):
                        try:
                            _parses(line)
                        except AssertionError as exc:
                            wrong.append(f"{where}: {exc}")
                            continue
                        name = " ".join(line.split()[:2])
                        if name not in ran:
                            wrong.append(f"{where}: `{name}` runs small in no block that runs")
    assert not wrong, "\n".join(wrong)


def test_an_output_block_follows_a_block_that_runs() -> None:
    for page in PAGES:
        blocks = blocks_of(page.read_text(encoding="utf-8"))
        for before, b in zip([None, *blocks], blocks, strict=False):
            if b.how == "output":
                assert before is not None and before.how in ("run", "serve", "slow", "serve slow"), \
                    f"{_name(page)}:{b.line}: an <!-- output --> block follows no block that runs"


# Tutorials that run end to end offline; a tutorial around servers a person uses in a browser
# (collecting recordings, annotating) runs its "without participants" script instead.
OFFLINE = ("first-inference", "your-robot", "reproduce-paper", "own-recordings", "own-participants")


def test_every_offline_tutorial_has_runnable_blocks() -> None:
    names = {p.stem for p in TUTORIALS}
    assert set(OFFLINE) <= names, f"missing tutorials: {set(OFFLINE) - names}"
    for page in TUTORIALS:
        if page.stem in OFFLINE:
            assert runnable_blocks(page.read_text(encoding="utf-8")), f"{page.name} has no <!-- run --> block"


def _check(expected: Expected | None, printed: str, wrong: list[str]) -> None:
    if expected is not None:
        why = mismatch(expected, printed)
        if why:
            wrong.append(why)


def _run_block(page: Path, k: int, b: Block, code: str, work: Path, env: dict[str, str],
               output: Block | None, wrong: list[str]) -> None:
    """Run one block; what its page says it prints that it does not print goes to ``wrong``."""
    where = f"{_name(page)} block {k} (line {b.line})"
    stated_all = Expected(f"{_name(page)}:{output.line}", output.code, b.tol) if output is not None else None
    if b.lang == "python":
        said, bad = python_expectations(code, _name(page), b.line, b.tol)
        wrong.extend(bad)
        trace = work / "_printed.json"
        res = subprocess.run([sys.executable, "-c", run_python_source(code, str(trace)), str(trace)], cwd=work,
                             env=env, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, f"{where} (python) failed:\n{code}\n{res.stderr[-2000:]}"
        printed = printed_by_line(json.loads(trace.read_text(encoding="utf-8")))
        for line, stated in said.items():
            _check(stated, printed.get(line, ""), wrong)
        _check(stated_all, res.stdout, wrong)
        return
    if b.lang in ("bash", "sh"):
        res = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=work, env=env, capture_output=True,
                             text=True, timeout=600)
        assert res.returncode == 0, f"{where} (bash) failed:\n{res.stdout[-1500:]}\n{res.stderr[-2000:]}"
        _check(stated_all, res.stdout, wrong)
        return
    commands = console_expectations(code, _name(page), b.line, b.tol)
    for n, (cmd, expected) in enumerate(commands):
        res = subprocess.run(["bash", "-c", cmd], cwd=work, env=env, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, f"{where}: `{cmd}` failed:\n{res.stderr[-2000:]}"
        _check(expected, res.stdout, wrong)
        if n == len(commands) - 1:
            _check(stated_all, res.stdout, wrong)


def _slow(page: Path) -> bool:
    return any(b.how in ("slow", "serve slow") for b in blocks_of(page.read_text(encoding="utf-8")))


def _fast(page: Path) -> bool:
    return any(b.how in ("run", "serve") for b in blocks_of(page.read_text(encoding="utf-8")))


def _run_page(page: Path, tmp_path: Path, with_slow: bool) -> None:
    work = tmp_path / "work"
    work.mkdir()
    for name in ("docs", "data", "recipes"):  # the pages speak from the root of a clone
        (work / name).symlink_to(ROOT / name)
    env = _env(_bindir(tmp_path))
    env.setdefault("COLUMNS", "100")
    blocks = blocks_of(page.read_text(encoding="utf-8"))
    wrong: list[str] = []
    server: _Server | None = None  # one server for the page's serve blocks, as a reader keeps one running
    try:
        for k, b in enumerate(blocks):
            output = blocks[k + 1] if k + 1 < len(blocks) and blocks[k + 1].how == "output" else None
            if b.how == "run" or (b.how == "slow" and with_slow):
                _run_block(page, k, b, b.code, work, env, output, wrong)
            elif b.how == "serve" or (b.how == "serve slow" and with_slow):
                pytest.importorskip("fastapi", reason="siftom serve needs the serve extra")
                server = server or _Server(work, env)
                code = b.code.replace("localhost:8000", f"localhost:{server.port}")
                _run_block(page, k, b, code.replace("127.0.0.1:8000", f"127.0.0.1:{server.port}"), work, env,
                           output, wrong)
    finally:
        if server is not None:
            server.stop()
    assert not wrong, "what the page states differs from what the code prints (edit the page):\n\n" + "\n\n".join(wrong)


FAST = [p for p in PAGES if _fast(p)]
SLOW = [p for p in PAGES if _slow(p)]


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
@pytest.mark.parametrize("page", FAST, ids=[_name(p) for p in FAST])
def test_tutorial_blocks_run(page: Path, tmp_path: Path) -> None:
    """The blocks of a page that run, except its slow ones; what they print is what the page says."""
    _run_page(page, tmp_path, with_slow=False)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
@pytest.mark.parametrize("page", SLOW, ids=[_name(p) for p in SLOW])
def test_page_blocks_run_with_the_slow_ones(page: Path, tmp_path: Path) -> None:
    _run_page(page, tmp_path, with_slow=True)
