"""``siftom serve`` passes its flags as one frozen ``ServeOptions`` record."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from siftom.cli import service
from siftom.cli.records import options_of
from siftom.cli.service import ServeOptions, serve_cmd


def test_every_flag_is_a_field() -> None:
    assert options_of(serve_cmd) is ServeOptions
    fields = {f.name for f in dataclasses.fields(ServeOptions)}
    params = {p.name for p in serve_cmd.params if p.expose_value}
    assert params == fields


def test_flags_reach_the_record(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[ServeOptions] = []
    monkeypatch.setattr(service, "_serve", seen.append)
    out = CliRunner().invoke(serve_cmd, ["--port", "8123", "--max-sessions", "7", "--allow-host", "a.example",
                                         "--allow-host", "b.example", "--header-timeout", "2.5"])
    assert out.exit_code == 0, out.output
    (opts,) = seen
    assert (opts.port, opts.max_sessions, opts.allow_host, opts.header_timeout) == (
        8123, 7, ("a.example", "b.example"), 2.5)
    assert opts.host == "127.0.0.1" and opts.data_dir is None and opts.trusted_proxy == ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.port = 1  # type: ignore[misc]


def test_no_service_function_over_eight_parameters() -> None:
    tree = ast.parse(textwrap.dedent(inspect.getsource(service)))
    wide = [n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
            and len(n.args.posonlyargs) + len(n.args.args) + len(n.args.kwonlyargs) > 8]
    assert "serve_cmd" not in wide and "_serve" not in wide
    assert Path(inspect.getsourcefile(service) or "").name == "service.py"
