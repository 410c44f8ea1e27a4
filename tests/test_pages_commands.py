"""Every command a page names exists: each ``python path/to/script.py`` of README.md and docs/ (in a
code block or an inline code span) names a file of the repository, and each ``siftom ...`` line
names a command of the CLI with options it has (parsed, nothing runs)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click
import pytest

from siftom.cli import root

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
FENCE = re.compile(r"^```(\w*)\n(.*?)\n```$", re.DOTALL | re.MULTILINE)
INLINE = re.compile(r"(?<!`)`((?:[^`\n]|\n(?!\n))+)`(?!`)")  # a span may wrap onto the next line
STARTS = re.compile(r"\s*(?:[A-Z_]+=\S+\s+)*(?:\S*/)?(?:python3?|siftom)\s")
SHELL = ("", "console", "sh", "bash", "shell", "text")
# python (or .venv/bin/python, python3), after optional VAR=value prefixes, then the script it runs
SCRIPT = re.compile(r"(?:^|[\s;&|(])(?:\S*/)?python3?\s+(?!-)(\S+\.py)\b")
SIFTOM = re.compile(r"(?:^|[\s;&|(])(?<!from )(?<!import )(?:\.venv/bin/)?siftom\s+[a-z][\w-]*(?!\w|-|:)")


def _commands(text: str) -> list[tuple[int, str]]:
    """(line number, command) of every command line of a page: fenced blocks' lines (continuations
    joined, ``$ `` prompts dropped) and inline code spans."""
    out: list[tuple[int, str]] = []
    fenced: list[tuple[int, int]] = []
    for m in FENCE.finditer(text):
        fenced.append((m.start(), m.end()))
        if m.group(1) not in SHELL:  # python, json, toml: no command lines
            continue
        first = text[:m.start(2)].count("\n") + 1
        lines = m.group(2).split("\n")
        k = 0
        while k < len(lines):
            line, at = lines[k], first + k
            while line.rstrip().endswith("\\") and k + 1 < len(lines):
                k += 1
                line = line.rstrip()[:-1] + " " + lines[k].strip()
            k += 1
            line = line[2:] if line.startswith("$ ") else line
            out.append((at, line.strip()))
    for m in INLINE.finditer(text):
        if any(a <= m.start() < b for a, b in fenced) or not STARTS.match(m.group(1)):
            continue  # a span in prose is a command when it starts with one (not a quoted message)
        out.append((text[:m.start()].count("\n") + 1, " ".join(m.group(1).split())))
    return out


def _siftom_words(line: str) -> list[str] | None:
    """The words of the ``siftom`` command in ``line`` (from ``siftom`` to the end of the command)."""
    m = SIFTOM.search(line)
    if m is None:
        return None
    rest = line[m.start():].lstrip(" ;&|(")
    rest = re.split(r"\s(?:#|&&|\|\||\||;|>)\s?", " " + rest.split("  #")[0])[1 if rest.startswith(" ") else 0]
    rest = rest.strip().rstrip("&").strip().rstrip(")`")
    try:
        words = shlex.split(rest)
    except ValueError:
        words = rest.split()
    words[0] = "siftom"
    return words


def _check_siftom(words: list[str]) -> str | None:
    """Why ``words`` is no command of the CLI (None: it is one, with options it has)."""
    cmd: click.Command = root
    args, path = words[1:], "siftom"
    while isinstance(cmd, click.Group):
        if not args or args[0].startswith("-"):
            return None if not args or args[0] in ("--help", "--version") else f"{path} needs a command"
        if args[0] not in cmd.commands:
            return f"{path} has no command {args[0]!r}"
        cmd, path, args = cmd.commands[args[0]], f"{path} {args[0]}", args[1:]
    known = {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)} | {"--help"}
    for a in args:
        if re.fullmatch(r"--?[A-Za-z][\w-]*(=.*)?", a) and a.split("=")[0] not in known:
            return f"{path} has no option {a.split('=')[0]}"
    return None


def _page_id(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("page", PAGES, ids=[_page_id(p) for p in PAGES])
def test_every_script_a_page_runs_exists(page: Path) -> None:
    missing = []
    for line_no, cmd in _commands(page.read_text(encoding="utf-8")):
        for m in SCRIPT.finditer(cmd):
            script = m.group(1)
            if not (ROOT / script).is_file():
                missing.append(f"{_page_id(page)}:{line_no}: `{cmd[:120]}` runs {script}, which the repository lacks")
    assert not missing, "\n".join(missing)


@pytest.mark.parametrize("page", PAGES, ids=[_page_id(p) for p in PAGES])
def test_every_siftom_command_a_page_names_parses(page: Path) -> None:
    wrong = []
    for line_no, cmd in _commands(page.read_text(encoding="utf-8")):
        words = _siftom_words(cmd)
        if words is None:
            continue
        why = _check_siftom(words)
        if why:
            wrong.append(f"{_page_id(page)}:{line_no}: `{cmd[:120]}`: {why}")
    assert not wrong, "\n".join(wrong)


def test_the_scanner_finds_what_it_checks() -> None:
    text = ("Run `python recipes/none.py --x` then:\n\n```sh\nPYTHONPATH=src python benchmarks/a.py D \\\n"
            "    --out R\n$ siftom infer --scenario kitchen-cereal-v0 --no-such-flag   # note\n```\n")
    cmds = dict(_commands(text))
    assert [SCRIPT.search(c).group(1) for c in cmds.values() if SCRIPT.search(c)] == [  # type: ignore[union-attr]
        "benchmarks/a.py", "recipes/none.py"]
    words = _siftom_words(cmds[6])
    assert words == ["siftom", "infer", "--scenario", "kitchen-cereal-v0", "--no-such-flag"]
    assert _check_siftom(words) == "siftom infer has no option --no-such-flag"
    assert _check_siftom(["siftom", "bench", "trials", "--rules", "teammate"]) is None
    assert _check_siftom(["siftom", "bench", "nothing"]) == "siftom bench has no command 'nothing'"
