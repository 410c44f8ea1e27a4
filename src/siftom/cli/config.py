"""``siftom config show``: every setting, resolved, and where each value came from."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click


@click.group("config")
def config_group() -> None:
    """The settings (siftom.settings): a TOML file, SIFTOM_* variables and flags."""


@config_group.command("show")
@click.option("--config", "config_file", type=click.Path(path_type=Path), default=None,
              help="A TOML settings file (default: SIFTOM_CONFIG, if set).")
@click.option("--set", "pairs", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Set one value as a flag would (highest precedence); repeatable.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON: [{key, value, source}].")
def show_cmd(config_file: Path | None, pairs: tuple[str, ...], as_json: bool) -> None:
    """Print the resolved settings; precedence: flags > environment > file > defaults."""
    from siftom.errors import SettingsError
    from siftom.settings import Settings

    flags: dict[str, str] = {}
    for p in pairs:
        key, sep, value = p.partition("=")
        if not sep or "." not in key:
            raise SettingsError(f"--set {p!r}: write SECTION.KEY=VALUE, e.g. --set infer.likelihood=acoustic")
        flags[key.strip()] = value
    rows = Settings.load(config_file, flags=flags).show()
    if as_json:
        click.echo(json.dumps([{"key": k, "value": v, "source": s} for k, v, s in rows], indent=2, default=str))
        return
    width = max(len(k) for k, _, _ in rows)
    for k, v, src in rows:
        click.echo(f"{k:<{width}}  {v!r:<28}  {src}")


@config_group.command("env")
@click.option("--json", "as_json", is_flag=True, help="Print JSON: [{name, meaning, set, value}].")
def env_cmd(as_json: bool) -> None:
    """Every SIFTOM_* variable siftom reads outside the sections, what it means, and whether it is set
    (keys and tokens are shown only as set)."""
    from siftom.settings import environment

    rows: list[dict[str, Any]] = []
    for name, meaning in environment.VARIABLES.items():
        value = environment.read(name)
        secret = name.endswith(("_API_KEY", "_TOKEN")) or name == environment.TOKEN
        rows.append({"name": name, "meaning": meaning, "set": value is not None,
                     "value": None if value is None or secret else value})
    if as_json:
        click.echo(json.dumps(rows, indent=2))
        return
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        state = "(set)" if r["set"] and r["value"] is None else (repr(r["value"]) if r["set"] else "-")
        click.echo(f"{r['name']:<{width}}  {state:<12}  {r['meaning']}")
    click.echo("The sections' own variables (SIFTOM_INFER_LIKELIHOOD ...): siftom config show")


def register(root: click.Group) -> None:
    root.add_command(config_group)
