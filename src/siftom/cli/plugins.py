"""``siftom plugins``: what is registered (likelihoods, ASR engines, voices, domains, decision
rules, LLM backends …) and whether each can be used on this machine, with the fix if not."""

from __future__ import annotations

import json

import click


@click.command("plugins")
@click.option("--kind", default=None, help="Only this registry (e.g. 'voice', 'domain').")
@click.option("--json", "as_json", is_flag=True, help="Print JSON: {kind: [{name, summary, available, missing?}]}.")
def plugins_cmd(kind: str | None, as_json: bool) -> None:
    """List every registered plug-in and whether it is usable here (and how to fix it if not)."""
    from rich.console import Console
    from rich.table import Table

    from siftom.errors import unknown_name
    from siftom.registry import load_all, plugin_errors

    regs = dict(load_all())
    for name, why in plugin_errors().items():
        click.echo(f"warning: the plug-in {name!r} failed to register: {why}", err=True)
    if kind is not None:
        if kind not in regs:
            raise unknown_name("registry", kind, regs)
        regs = {kind: regs[kind]}
    if as_json:
        click.echo(json.dumps({k: [e.to_json() for e in r.describe()] for k, r in regs.items()}, indent=2))
        return
    table = Table(title="siftom plug-ins")
    for col in ("kind", "name", "usable", "summary / what is missing"):
        table.add_column(col)
    for k, r in regs.items():
        for line in r.describe():
            name = line.name + (" (default)" if line.name == r.default else "")
            table.add_row(k, name, "yes" if line.available else "no", line.missing or line.summary)
    Console().print(table)


def register(root: click.Group) -> None:
    root.add_command(plugins_cmd)
