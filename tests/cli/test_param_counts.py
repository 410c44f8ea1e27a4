"""No function of the command line or the service takes more than eight parameters.

Every function (methods and functions defined inside functions too) of ``siftom.cli`` and
``siftom.service`` is counted from its source, and every click command they make from its
callback: the function under ``pass_options`` takes its one record, and a callback that takes
``**kwargs`` without a record counts each option it is handed. A record's generated
``__init__`` is no parameter list: its fields are the point.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import click

import siftom.cli
import siftom.service
from siftom.cli import root
from siftom.cli.records import options_of

MOST = 8
PACKAGES = (siftom.cli, siftom.service)


def _modules() -> Iterator[ModuleType]:
    for pkg in PACKAGES:
        yield pkg
        for info in pkgutil.walk_packages(pkg.__path__, f"{pkg.__name__}."):
            if info.name.rsplit(".", 1)[-1] != "__main__":  # running it would run the command line
                yield importlib.import_module(info.name)


def _count(args: ast.arguments) -> int:
    """What ``inspect.signature`` counts: positional, keyword-only, ``*args`` and ``**kwargs``."""
    return (len(args.posonlyargs) + len(args.args) + len(args.kwonlyargs)
            + (args.vararg is not None) + (args.kwarg is not None))


def wide_functions(source: str, where: str) -> list[str]:
    """``where:line name (n)`` for every function in ``source`` over ``MOST`` parameters."""
    return [f"{where}:{n.lineno} {n.name} ({_count(n.args)})" for n in ast.walk(ast.parse(source))
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef) and _count(n.args) > MOST]


def _commands(cmd: click.Command, path: str) -> Iterator[tuple[str, click.Command]]:
    yield path, cmd
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            yield from _commands(sub, f"{path} {name}")


def parameters(cmd: click.Command) -> int:
    """How many parameters a command's callback takes: its record's function takes one; a callback
    that takes ``**kwargs`` without a record is handed every exposed option one by one."""
    fn = inspect.unwrap(cmd.callback) if cmd.callback is not None else None
    if fn is None:
        return 0
    sig = inspect.signature(fn).parameters.values()
    if options_of(cmd) is None and any(p.kind is inspect.Parameter.VAR_KEYWORD for p in sig):
        return len(sig) - 1 + sum(1 for p in cmd.params if p.expose_value)
    return len(sig)


def test_no_function_over_eight_parameters() -> None:
    wide = []
    for mod in _modules():
        file = inspect.getsourcefile(mod)
        assert file is not None
        wide += wide_functions(Path(file).read_text(encoding="utf-8"), mod.__name__)
    assert wide == [], "give these a record of their options (siftom.cli.records.pass_options): " + ", ".join(wide)


def test_no_command_callback_over_eight_parameters() -> None:
    ours = tuple(p.__name__ + "." for p in PACKAGES)
    checked, wide = 0, []
    for path, cmd in _commands(root, "siftom"):
        fn = inspect.unwrap(cmd.callback) if cmd.callback is not None else None
        if fn is None or not fn.__module__.startswith(ours):
            continue
        checked += 1
        if parameters(cmd) > MOST:
            wide.append(f"{path} ({parameters(cmd)})")
    assert checked > 20  # the walk reached the commands
    assert wide == []


def test_the_counts_see_a_wide_function() -> None:
    src = "def f(a, b, c, d, e, f, g, h, *, i): pass\nclass C:\n    def m(self, a, b, c, d, e, f, g, **k): pass\n"
    assert wide_functions(src, "m") == ["m:1 f (9)", "m:3 m (9)"]
    assert wide_functions("def outer():\n    def inner(a, b, c, d, e, f, g, h, i): pass\n", "m") == [
        "m:2 inner (9)"]
    assert wide_functions("def f(a, b, c, d, e, f, g, h): pass\n", "m") == []


def test_the_counts_see_options_handed_as_kwargs() -> None:
    @click.command()
    @click.option("--a")
    @click.option("--b")
    @click.option("--c")
    @click.option("--d")
    @click.option("--e")
    @click.option("--f")
    @click.option("--g")
    @click.option("--h")
    @click.option("--i")
    def wide(**flags: object) -> None:
        pass

    assert parameters(wide) == 9
