"""Sizes of the package's code: long files, long functions, many parameters, loose dictionaries.

``python tests/code_sizes.py`` prints each list; ``tests/test_sizes.py`` holds them to the limits.
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "siftom"
FILE_LINES = 400
FUNCTION_LINES = 80
PARAMETERS = 8
LOOSE = ("dict[str, Any]", "Dict[str, Any]")


@dataclass(frozen=True)
class Sizes:
    long_files: tuple[tuple[str, int], ...]
    long_functions: tuple[tuple[str, int], ...]
    many_parameters: tuple[tuple[str, int], ...]
    loose_signatures: tuple[str, ...]


def _public(name: str) -> bool:
    return not name.startswith("_") or (name.startswith("__") and name.endswith("__"))


def _functions(tree: ast.Module) -> list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef, bool]]:
    """(qualified name, node, public) for every function and method."""
    out: list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef, bool]] = []

    def walk(node: ast.AST, prefix: str, public: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                out.append((name, child, public and _public(child.name)))
                walk(child, f"{name}.", False)  # nested functions are not public
            elif isinstance(child, ast.ClassDef):
                walk(child, f"{prefix}{child.name}.", public and _public(child.name))

    walk(tree, "", True)
    return out


def _parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    return len([n for n in names if n not in ("self", "cls")])


def _loose(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    a = fn.args
    notes = [x.annotation for x in (*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg)
             if x is not None and x.annotation is not None]
    if fn.returns is not None:
        notes.append(fn.returns)
    return any(any(loose in ast.unparse(n) for loose in LOOSE) for n in notes)


def measure(src: Path = SRC) -> Sizes:
    files, functions, params, loose = [], [], [], []
    for path in sorted(src.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        rel = path.relative_to(src).as_posix()
        lines = len(text.splitlines())
        if lines > FILE_LINES:
            files.append((rel, lines))
        for name, fn, public in _functions(ast.parse(text)):
            where = f"{rel}:{name}"
            length = (fn.end_lineno or fn.lineno) - fn.lineno + 1
            if length > FUNCTION_LINES:
                functions.append((where, length))
            if _parameters(fn) > PARAMETERS:
                params.append((where, _parameters(fn)))
            if public and _loose(fn):
                loose.append(where)
    return Sizes(tuple(files), tuple(functions), tuple(params), tuple(loose))


def main() -> int:
    s = measure()
    print(f"files over {FILE_LINES} lines: {len(s.long_files)}")
    for where, n in s.long_files:
        print(f"  {n:5d}  {where}")
    print(f"functions over {FUNCTION_LINES} lines: {len(s.long_functions)}")
    for where, n in s.long_functions:
        print(f"  {n:5d}  {where}")
    print(f"functions with more than {PARAMETERS} parameters: {len(s.many_parameters)}")
    for where, n in sorted(s.many_parameters, key=lambda x: -x[1]):
        print(f"  {n:5d}  {where}")
    by_package = Counter(w.split("/")[0] if "/" in w.split(":")[0] else "(root)" for w in s.loose_signatures)
    print(f"public signatures with dict[str, Any]: {len(s.loose_signatures)}  {dict(by_package.most_common())}")
    if "-v" in sys.argv:
        for where in s.loose_signatures:
            print(f"  {where}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
