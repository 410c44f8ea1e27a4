"""Commands with many options take them as one frozen record (``siftom.cli.records``).

For each such command: the record's fields are exactly the command's options, and a command
line that sets every option to something other than its default reaches the record field by
field (nested records included), as click parsed it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import click
import pytest

from siftom.cli import root
from siftom.cli.records import build, field_names, options_of, pass_options

RECORDED = {
    "siftom infer", "siftom dataset build", "siftom eval", "siftom bench understanding", "siftom bench trials",
    "siftom collect", "siftom annotate", "siftom perceive", "siftom listen", "siftom ros", "siftom serve",
    "siftom bench serve", "siftom bench robots",
}


def _commands(cmd: click.Command, path: str) -> Iterator[tuple[str, click.Command]]:
    yield path, cmd
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            yield from _commands(sub, f"{path} {name}")


WITH_RECORDS = {path: cmd for path, cmd in _commands(root, "siftom") if options_of(cmd) is not None}


def _value(p: click.Parameter) -> Any:
    """A value for ``p`` other than its default, as it would be typed (None: leave it out)."""
    t = p.type
    if isinstance(p, click.Option) and p.is_flag:
        return None if p.default else True
    if isinstance(t, click.Choice):
        choices = [c for c in t.choices if c != p.default]
        return str(choices[-1]) if choices else None
    if isinstance(t, click.types.IntParamType | click.types.FloatParamType):
        lo = getattr(t, "min", None)
        for cand in ((p.default or 0) + 1, lo, (lo or 0) + 1):
            if cand is None or cand == p.default:
                continue
            try:
                t.convert(cand, p, None)
            except click.BadParameter:
                continue
            return str(cand)
        return None
    if isinstance(t, click.Path) and t.exists:
        return None  # a file that must exist: its default is enough
    return f"given-{p.name}"


def _argv(cmd: click.Command) -> tuple[list[str], dict[str, Any]]:
    """A command line that sets every exposed parameter it can, and the values given, by name."""
    argv: list[str] = []
    given: dict[str, Any] = {}
    for p in cmd.params:
        if not p.expose_value:
            continue
        value = _value(p)
        if value is None:
            continue
        given[p.name or ""] = value
        if isinstance(p, click.Argument):
            argv.append(value)
        elif isinstance(p, click.Option) and p.is_flag:
            argv.append(p.opts[0])
        else:
            argv += [p.opts[0], value] * (2 if getattr(p, "multiple", False) else 1)
    return argv, given


def _flat(record: object) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in dataclasses.fields(record):  # type: ignore[arg-type]
        v = getattr(record, f.name)
        out.update(_flat(v) if dataclasses.is_dataclass(v) else {f.name: v})
    return out


def test_the_wide_commands_take_records() -> None:
    assert set(WITH_RECORDS) >= RECORDED


@pytest.mark.parametrize("path", sorted(WITH_RECORDS))
def test_every_option_is_a_field(path: str) -> None:
    cmd = WITH_RECORDS[path]
    record = options_of(cmd)
    assert record is not None
    names = field_names(record)
    assert len(names) == len(set(names))
    assert set(names) == {p.name for p in cmd.params if p.expose_value}


@pytest.mark.parametrize("path", sorted(WITH_RECORDS))
def test_every_option_reaches_its_field(path: str) -> None:
    cmd = WITH_RECORDS[path]
    record_cls = options_of(cmd)
    assert record_cls is not None
    argv, given = _argv(cmd)
    assert len(given) >= 3  # the command line sets most options
    ctx = cmd.make_context(path.split()[-1], argv)
    record = build(record_cls, dict(ctx.params))
    assert _flat(record) == ctx.params
    defaults = {p.name: p.default for p in cmd.params}
    for name in given:
        assert ctx.params[name] != defaults[name], name  # the value given, not the default, arrived
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(record, dataclasses.fields(record)[0].name, None)


@dataclasses.dataclass(frozen=True)
class _Inner:
    b: int


@dataclasses.dataclass(frozen=True)
class _Outer:
    a: str
    inner: _Inner


def test_a_nested_record_gathers_its_fields() -> None:
    assert build(_Outer, {"a": "x", "b": 2}) == _Outer("x", _Inner(2))
    assert field_names(_Outer) == ["a", "b"]
    with pytest.raises(TypeError):
        build(_Outer, {"a": "x", "b": 2, "c": 3})  # an option no field takes
    with pytest.raises(TypeError):
        build(_Outer, {"a": "x"})  # a field no option fills


def test_a_command_gets_its_record() -> None:
    seen: list[_Outer] = []

    @click.command()
    @click.option("--a", default="x")
    @click.option("--b", type=int, default=1)
    @pass_options(_Outer)
    def cmd(args: _Outer) -> None:
        """Say hello."""
        seen.append(args)

    assert cmd.help == "Say hello."
    cmd.main(["--b", "5"], standalone_mode=False)
    assert seen == [_Outer("x", _Inner(5))]


def test_only_frozen_records() -> None:
    @dataclasses.dataclass
    class Loose:
        a: int

    with pytest.raises(TypeError, match="frozen"):
        pass_options(Loose)
