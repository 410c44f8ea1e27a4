"""``siftom config show``: every setting, resolved, and where each value came from."""

from __future__ import annotations

import json
from pathlib import Path

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


def register(root: click.Group) -> None:
    root.add_command(config_group)
