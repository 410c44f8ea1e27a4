"""A command's click options arrive as one frozen record.

Each command with many options declares a frozen dataclass whose fields are the options'
parameter names, and takes that one record::

    @dataclasses.dataclass(frozen=True)
    class EchoOptions:
        text: str
        loud: bool

    @click.command("echo")
    @click.option("--text", required=True)
    @click.option("--loud", is_flag=True)
    @pass_options(EchoOptions)
    def echo_cmd(opts: EchoOptions) -> None:
        click.echo(opts.text.upper() if opts.loud else opts.text)

``pass_options`` goes right above the function, below the options: click hands the callback
its keyword arguments and the callback builds the record, so a field that no option fills (or
an option that no field takes) fails on the first call, and ``options_of`` tells tests which
record a command takes. A field whose type is itself a frozen dataclass gathers that record's
fields from the same keyword arguments: options that several commands share (a decorator that
adds a group of them) arrive as one record inside each command's.
"""

from __future__ import annotations

import dataclasses
import functools
import sys
from collections.abc import Callable
from typing import Any, TypeVar

import click

Opts = TypeVar("Opts")
R = TypeVar("R")

_RECORD = "__siftom_options__"


def pass_options(cls: type[Opts]) -> Callable[[Callable[[Opts], R]], Callable[..., R]]:
    """Hand the decorated command its click keyword arguments as one ``cls`` record.

    Args:
        cls: a frozen dataclass with one field per exposed option or argument of the command.

    Raises:
        TypeError: ``cls`` is not a frozen dataclass.
    """
    if not (dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen):  # type: ignore[attr-defined]
        raise TypeError(f"{cls.__name__} must be a frozen dataclass: @dataclasses.dataclass(frozen=True)")

    def decorate(fn: Callable[[Opts], R]) -> Callable[..., R]:
        @functools.wraps(fn)
        def callback(**flags: Any) -> R:
            return fn(build(cls, flags))

        setattr(callback, _RECORD, cls)
        return callback

    return decorate


def _nested(cls: type[Any]) -> dict[str, type[Any]]:
    """The fields of ``cls`` that are records themselves, with their classes (a field's type named
    as a plain name of the record's module, as ``from __future__ import annotations`` leaves it)."""
    scope = vars(sys.modules[cls.__module__])
    found: dict[str, type[Any]] = {}
    for f in dataclasses.fields(cls):
        hint = scope.get(f.type) if isinstance(f.type, str) else f.type
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            found[f.name] = hint
    return found


def build(cls: type[Opts], flags: dict[str, Any]) -> Opts:
    """The record ``cls`` from click's keyword arguments (nested records gather their own fields).

    Raises:
        TypeError: an argument that no field takes, or a field that no argument fills.
    """
    rest = dict(flags)
    inner = {name: build(sub, {n: rest.pop(n) for n in field_names(sub) if n in rest})
             for name, sub in _nested(cls).items()}
    return cls(**rest, **inner)


def field_names(cls: type[Any]) -> list[str]:
    """Every option's name that the record ``cls`` takes, those of nested records included."""
    nested = _nested(cls)
    names: list[str] = []
    for f in dataclasses.fields(cls):
        names.extend(field_names(nested[f.name]) if f.name in nested else [f.name])
    return names


def options_of(command: click.Command) -> type[Any] | None:
    """The record class a command's callback takes (None: it takes its options one by one)."""
    record: type[Any] | None = getattr(command.callback, _RECORD, None)
    return record
