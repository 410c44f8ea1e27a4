"""``siftom simulate``: L_single, L_team and speedup of a robot command in a scenario."""

from __future__ import annotations

import json

import click


@click.command("simulate")
@click.argument("scenario_id")
@click.option("--command", "command", required=True,
              help='Robot command, e.g. "deliver(fork,3)" or "fetch(cereal)".')
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def simulate_cmd(scenario_id: str, command: str, as_json: bool) -> None:
    """Simulate the human alone and with the robot executing COMMAND; print the speedup."""
    from siftom.agents.team import simulate_scenario
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    res = simulate_scenario(sc, sc.parse_command(command))
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    click.echo(f"{sc.id}: goal {sc.goal.describe()}; robot command {res.command}")
    click.echo(f"  L_single = {res.l_single:g} steps (human alone)")
    click.echo(f"  L_team   = {res.l_team:g} steps (observed {res.prefix:g} + max(human {res.human_steps:g}, "
               f"robot {res.robot_steps:g}) + remedy {res.remedy_steps:g})")
    click.echo(f"  speedup  = L_single / L_team - 1 = {res.speedup:+.3f}"
               f"   (useful objects {res.useful}, wrong {res.wrong})")


def register(root: click.Group) -> None:
    root.add_command(simulate_cmd)
