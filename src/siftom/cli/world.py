"""World commands: ``siftom scene ...`` (scene graphs).

Thin wrappers over :mod:`siftom.world.scenegraph`; errors are raised as SiftomError
subclasses and printed on one line by ``siftom.cli.main``.
"""

from __future__ import annotations

import json
import shutil
import textwrap
from collections import Counter
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.table import Table
from rich.text import Text

from siftom.world.scenegraph import SceneGraph, SymbolicScene, class_counts


@click.group()
def scene() -> None:
    """Look at scene graphs (VirtualHome JSON)."""


def _inspect_summary(graph: SceneGraph, scene_view: SymbolicScene) -> dict[str, Any]:
    """The facts ``scene inspect`` prints, as a JSON-ready dict."""
    room_name: dict[int | None, str] = {r.id: r.name for r in scene_view.rooms}  # None: in no room
    in_room = Counter(p.room for p in scene_view.placements)
    held = Counter(p.parent for p in scene_view.placements)
    grabbable_in_room = Counter(scene_view.room_of(i) for i in scene_view.grabbables)
    return {
        "num_nodes": len(graph.nodes),
        "num_edges": len(graph.edges),
        "rooms": [{"id": r.id, "name": r.name, "num_nodes": in_room[r.id],
                   "num_grabbable": grabbable_in_room[r.id]} for r in scene_view.rooms],
        "containers": [
            {"id": c.id, "class_name": c.class_name, "room": scene_view.room_of(c.id),
             "room_name": room_name.get(scene_view.room_of(c.id)), "openable": c.openable,
             "open": c.is_open, "num_inside": held[c.id]}
            for c in scene_view.containers],
        "surfaces": [
            {"id": s, "class_name": graph.node(s).class_name, "room": scene_view.room_of(s),
             "room_name": room_name.get(scene_view.room_of(s)), "num_on": held[s]}
            for s in scene_view.surfaces],
        "objects_by_class": class_counts(graph.node(i) for i in scene_view.grabbables),
    }


def _print_summary(path: Path, info: dict[str, Any]) -> None:
    console = Console(highlight=False)
    # The path is text, not markup (a folder may be called "[draft]"), and the line is left to the
    # terminal to wrap: what it says does not depend on the width or on how long the path is.
    console.print(Text.assemble(
        (str(path), "bold"),
        f": {info['num_nodes']} nodes, {info['num_edges']} edges, "
        f"{len(info['rooms'])} rooms, {len(info['containers'])} containers, "
        f"{len(info['surfaces'])} surfaces, "
        f"{sum(info['objects_by_class'].values())} grabbable objects"), soft_wrap=True)

    # Names (no_wrap) are never shortened ("kitchenca…"); a narrow terminal folds other cells.
    rooms = Table(title="Rooms")
    for col in ("id", "room", "nodes", "grabbable"):
        rooms.add_column(col, justify="right" if col != "room" else "left", no_wrap=col == "room",
                         overflow="fold")
    for r in info["rooms"]:
        rooms.add_row(str(r["id"]), r["name"], str(r["num_nodes"]), str(r["num_grabbable"]))
    console.print(rooms)

    containers = Table(title="Containers")
    for col in ("id", "class", "room", "state", "inside"):
        containers.add_column(col, justify="right" if col in ("id", "inside") else "left",
                              no_wrap=col in ("class", "room"), overflow="fold")
    for c in info["containers"]:
        state = ("open" if c["open"] else "closed") if c["openable"] else "open (no door)"
        containers.add_row(str(c["id"]), c["class_name"], c["room_name"] or "-", state,
                           str(c["num_inside"]))
    console.print(containers)

    # Surfaces are many (every floor tile is one), so group them by class.
    by_class: dict[str, list[dict[str, Any]]] = {}
    for s in info["surfaces"]:
        by_class.setdefault(s["class_name"], []).append(s)
    surfaces = Table(title="Surfaces")
    for col in ("class", "count", "rooms", "objects on"):
        surfaces.add_column(col, justify="right" if col in ("count", "objects on") else "left",
                            no_wrap=col == "class", overflow="fold")
    for name, items in sorted(by_class.items(), key=lambda kv: (-len(kv[1]), kv[0])):
        where = sorted({s["room_name"] or "-" for s in items})
        surfaces.add_row(name, str(len(items)), ", ".join(where),
                         str(sum(s["num_on"] for s in items)))
    console.print(surfaces)

    objects = Table(title="Grabbable objects by class")
    objects.add_column("class", no_wrap=True, overflow="fold")
    objects.add_column("count", justify="right", overflow="fold")
    for name, count in info["objects_by_class"].items():
        objects.add_row(name, str(count))
    console.print(objects)


@scene.command("inspect")
@click.argument("file", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of tables.")
def inspect_cmd(file: Path, as_json: bool) -> None:
    """Show the rooms, containers, surfaces and objects of a scene-graph FILE."""
    graph = SceneGraph.load(file)
    info = _inspect_summary(graph, SymbolicScene.of(graph))
    if as_json:
        click.echo(json.dumps(info, indent=2))
    else:
        _print_summary(file, info)


@click.group()
def scenarios() -> None:
    """List and show the registered scenarios of the built-in domains."""


@scenarios.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("--domain", default=None, help="Only this domain (e.g. kitchen-v0).")
def scenarios_list(as_json: bool, domain: str | None) -> None:
    """List registered scenario ids with their domain and story."""
    from siftom.scenarios.base import domains, get_scenario, scenario_domain, scenario_ids

    known = [d.name for d in domains()]
    if domain is not None and domain not in known:
        from siftom.errors import unknown_name

        raise unknown_name("domain", domain, known)
    ids = [i for i in scenario_ids() if domain is None or scenario_domain(i) == domain]
    rows = []
    for sid in ids:
        sc = get_scenario(sid)
        rows.append({"id": sid, "domain": sc.domain, "goal": sc.goal.name, "command": str(sc.command),
                     "num_goals": len(sc.goals), "num_actions": len(sc.actions), "description": sc.description})
    if as_json:
        click.echo(json.dumps({"domains": [{"id": d.name, "description": d.summary} for d in domains()],
                               "scenarios": rows}, indent=2))
        return
    _print_scenario_rows(rows)


def _print_scenario_rows(rows: list[dict[str, Any]]) -> None:
    """One line per scenario (id, sizes, gold command), its story wrapped under it.

    Ids and commands are typed back into other commands, so they are never cut or wrapped; the
    columns fit 80 and only the story wraps, to the terminal's width (``COLUMNS`` where set).
    """
    width = shutil.get_terminal_size((100, 24)).columns
    id_w = max([len("id"), *(len(r["id"]) for r in rows)])
    click.echo(click.style(f"{'id':<{id_w}}  goals  actions  gold command", bold=True))
    for r in rows:
        click.echo(f"{r['id']:<{id_w}}  {r['num_goals']:>5}  {r['num_actions']:>7}  {r['command']}")
        click.echo(textwrap.fill(r["description"], width=max(40, width - 1),
                                 initial_indent="    ", subsequent_indent="    "))
    click.echo(f"{len(rows)} scenarios; one in full: siftom scenarios show ID")


@scenarios.command("show")
@click.argument("scenario_id")
@click.option("--png", "png", type=click.Path(path_type=Path), default=None, help="Write a top-down map here.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("--no-path", is_flag=True, help="Do not draw the human's trajectory on the map.")
@click.option("--step", type=int, default=None,
              help="Draw the state after this many observed actions (a camera frame; default: all).")
def scenarios_show(scenario_id: str, png: Path | None, as_json: bool, no_path: bool, step: int | None) -> None:
    """Show one scenario: places, objects, the goal and the human's observed actions."""
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(scenario_id)
    info = sc.to_json()
    if png is not None:
        from siftom.world.render import render_scenario

        render_scenario(sc, png, show_path=not no_path, step=step)
        info["png"] = str(png)
    if as_json:
        click.echo(json.dumps(info, indent=2))
        return
    con = Console()
    con.print(f"[bold]{sc.id}[/bold] ({sc.domain}): {sc.description}")
    con.print(f"goal: {sc.goal.name} = {sc.goal.describe()} on {info['target']}   "
              f"(goal space: {len(sc.goals)} goals)   gold command: {sc.command}")
    table = Table(title="places and objects when the human speaks")
    for col in ("place", "room", "kind", "objects"):
        table.add_column(col)
    now = sc.now
    for i, p in enumerate(sc.world.places):
        objs = Counter(sc.world.items[k].cls for k, loc in enumerate(now.item_at) if loc == i)
        kind = p.kind + ((" (open)" if now.is_open(i) else " (closed)") if p.closable else "")
        table.add_row(p.name, p.room, kind, ", ".join(f"{n}x{c}" if n > 1 else c for c, n in sorted(objs.items())))
    con.print(table)
    con.print("observed actions:")
    for k, a in enumerate(info["actions"], 1):
        con.print(f"  {k:2d}. {a}")
    if png is not None:
        con.print(f"map written to {png}")


def register(root: click.Group) -> None:
    """Add the world commands (``scene``, ``scenarios``) to the root command group."""
    root.add_command(scene)
    root.add_command(scenarios)
