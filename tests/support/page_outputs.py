"""What a page says a block prints, checked against what the block prints.

The convention (docs pages and README.md):

* In a ``python`` block that runs, a comment ``# -> TEXT`` on a line states what that line prints
  (every ``print`` called from the line, joined by newlines). Prose goes on its own comment line;
  a comment on a ``print`` line that is not ``# ->`` is an error (state the output, or move the
  remark to a line of its own).
* In a ``console`` block that runs, the lines after a ``$ command`` line, up to the next ``$``, are
  what the command prints on stdout.
* A fenced block marked ``<!-- output -->`` right after a block that runs is what that block
  prints (a Python block: everything it prints; a console block: its last command).

``TEXT`` matches the printed text whole, doctest-like: ``...`` stands for anything (on a line of
its own: any number of lines), a run of whitespace for any whitespace or none (line breaks included, so
a compact JSON answer may be folded over lines), and every number written with a decimal point for a
printed number within the tolerance: one unit of the last digit the page writes (``0.95``:
±0.01, ``90.2 %``: ±0.1) unless the block's mark gives ``tol=X`` (``<!-- run tol=0.05 -->``).
Integers and words match exactly. The stated values live in the page, not in a test: when the
code prints something else, the page is fixed by editing its text to what the failure says.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass

_NUMBER = re.compile(r"(?<![\w.])-?\d+\.\d+(?![\w]|\.\d)")
_ANY_NUMBER = r"(-?\d+(?:\.\d+)?(?:[eE]-?\d+)?)"
TRACE_PRELUDE = '''
import builtins as _b, io as _io, json as _j, sys as _s, atexit as _a
_said = []
_print = _b.print
def print(*args, **kw):
    f = _s._getframe(1)
    while f is not None and f.f_code.co_filename != "<page block>":
        f = f.f_back
    if f is not None and kw.get("file") in (None, _s.stdout):
        buf = _io.StringIO()
        _print(*args, **{**kw, "file": buf})
        _said.append([f.f_lineno, buf.getvalue()])
    _print(*args, **kw)
_b.print = print
_a.register(lambda: open(_s.argv[1], "w").write(_j.dumps(_said)))
'''


def run_python_source(code: str, trace_file: str) -> str:
    """``python -c`` source that runs ``code`` as ``<page block>`` and writes, at exit, the
    ``[line, text]`` of every print it made to ``trace_file`` (given as ``sys.argv[1]``)."""
    return (TRACE_PRELUDE + f"\nexec(compile({code!r}, '<page block>', 'exec'), {{'__name__': '__main__'}})\n")


@dataclass(frozen=True)
class Expected:
    """An output a page states: where, what, and the tolerance of its numbers (None: the default)."""

    where: str  # "README.md:42"
    text: str
    tol: float | None = None


def _pattern(text: str) -> tuple[re.Pattern[str], list[tuple[float, float]]]:
    """The regex of a stated output and, per number group, (stated value, tolerance)."""
    parts: list[str] = []
    numbers: list[tuple[float, float]] = []
    lines = text.strip().split("\n")
    for k, line in enumerate(lines):
        if line.strip() == "...":
            parts.append(r"(?:.*?)")
            continue
        pos = 0
        chunk = []
        for m in _NUMBER.finditer(line):
            chunk.append(_literal(line[pos:m.start()]))
            decimals = len(m.group(0).split(".")[1])
            numbers.append((float(m.group(0)), 10.0 ** -decimals))
            chunk.append(_ANY_NUMBER)
            pos = m.end()
        chunk.append(_literal(line[pos:]))
        parts.append("".join(chunk))
        if k < len(lines) - 1:
            parts.append(r"\s*")
    body = r"\s*".join(p for p in parts if p)
    return re.compile(r"\s*" + body + r"\s*", re.DOTALL), numbers


def _literal(s: str) -> str:
    out = []
    for piece in re.split(r"(\.\.\.|\s+)", s):
        if piece == "...":
            out.append(r".*?")
        elif piece and piece.isspace():
            out.append(r"\s*")  # JSON printed compact or folded over lines, tables aligned
        elif piece:
            out.append(re.escape(piece))
    return "".join(out)


def mismatch(expected: Expected, printed: str) -> str | None:
    """Why ``printed`` is not what ``expected`` states (None: it is)."""
    pattern, numbers = _pattern(expected.text)
    m = pattern.fullmatch(printed.strip())
    if m is None:
        return (f"{expected.where}: the page states\n    {_indent(expected.text)}\nthe code printed\n    "
                f"{_indent(printed.strip()) or '(nothing)'}")
    for k, ((value, default_tol), got) in enumerate(zip(numbers, m.groups(), strict=True)):
        tol = expected.tol if expected.tol is not None else default_tol
        if abs(float(got) - value) > tol * (1 + 1e-9):
            return (f"{expected.where}: number {k + 1} of the stated output is {value:g}, the code printed "
                    f"{got} (tolerance ±{tol:g})\n  the page states\n    {_indent(expected.text)}\n  the code "
                    f"printed\n    {_indent(printed.strip())}")
    return None


def _indent(s: str) -> str:
    return s.replace("\n", "\n    ")


COMMENT = re.compile(r"(?<![\"'])#\s?(->)?\s?(.*)$")


def python_expectations(code: str, where: str, first_line: int, tol: float | None) -> tuple[dict[int, Expected], list[str]]:
    """The ``# ->`` outputs of a python block by block line (1-based), and the misuse found: a
    remark after a ``print`` that states no output, a bare expression (it prints nothing)."""
    out: dict[int, Expected] = {}
    bad: list[str] = []
    for node in ast.walk(ast.parse(code)):  # REPL style: `res.speedup, res.questions` shows nothing in a script
        if isinstance(node, ast.Expr) and not isinstance(node.value, (ast.Call, ast.Constant, ast.Await)):
            bad.append(f"{where}:{first_line + node.lineno - 1}: a bare expression prints nothing when the block "
                       f"runs: print it and state `# -> WHAT IT PRINTS`: {ast.unparse(node)[:80]}")
    for k, line in enumerate(code.split("\n"), start=1):
        at = f"{where}:{first_line + k - 1}"
        if "# ->" in line:
            out[k] = Expected(at, line.split("# ->", 1)[1].strip(), tol)
        elif re.search(r"\bprint\(", line) and re.search(r"\)\s+#", line):
            bad.append(f"{at}: a comment after a print states no output: write `# -> WHAT IT PRINTS` "
                       f"(a remark goes on a line of its own): {line.strip()}")
    return out, bad


def printed_by_line(trace: list[list[object]]) -> dict[int, str]:
    """What each line of a block printed (its prints' text joined, trailing newline dropped)."""
    out: dict[int, str] = {}
    for line, text in trace:
        assert isinstance(line, int) and isinstance(text, str)
        out[line] = out.get(line, "") + text
    return {k: v.rstrip("\n") for k, v in out.items()}


def console_expectations(code: str, where: str, first_line: int, tol: float | None) -> list[tuple[str, Expected | None]]:
    """(command, its stated output or None) for each ``$`` command of a console block."""
    out: list[tuple[str, Expected | None]] = []
    cmd: str | None = None
    said: list[str] = []
    start = 0

    def close() -> None:
        if cmd is not None:
            text = "\n".join(said).strip("\n")
            out.append((cmd, Expected(f"{where}:{first_line + start}", text, tol) if text.strip() else None))

    lines = code.split("\n")
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("$ "):
            close()
            cmd, said, start = line[2:], [], k
            while cmd.endswith("\\") and k + 1 < len(lines):
                k += 1
                cmd = cmd[:-1] + " " + lines[k].strip()
        elif cmd is not None:
            said.append(line)
        k += 1
    close()
    return out
