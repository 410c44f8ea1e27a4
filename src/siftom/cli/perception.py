"""``siftom perceive FRAME... --out world.json --actions-out actions.txt``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import click

from siftom.cli.records import pass_options


@dataclasses.dataclass(frozen=True)
class PerceiveFlags:
    """The ``siftom perceive`` frames and flags as one record."""

    frames: tuple[Path, ...]
    world_file: Path | None
    out: Path
    actions_out: Path
    graph_out: Path | None
    goal_space: str | None
    target: str | None
    no_goals: bool
    model: str | None
    llm_base_url: str | None
    no_cache: bool
    max_tokens: int
    as_json: bool


@click.command("perceive")
@click.argument("frames", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--world", "world_file", type=click.Path(path_type=Path), default=None,
              help="The known world at the first frame (world JSON or VirtualHome graph): only actions and goals are asked for.")
@click.option("--out", "out", type=click.Path(path_type=Path), required=True, help="Write the world JSON here.")
@click.option("--actions-out", type=click.Path(path_type=Path), required=True,
              help="Write the person's actions here, one per line.")
@click.option("--graph-out", type=click.Path(path_type=Path), default=None,
              help="Also write the scene graph seen in the first frame (VirtualHome JSON).")
@click.option("--goal-space", default=None, help="Merge a goal library: household-table-v0 or kitchen-v0.")
@click.option("--target", default=None, help="The place goals refer to (default: the model proposes it).")
@click.option("--no-goals", is_flag=True, help="Do not ask the model for goals (needs --goal-space or goals in --world).")
@click.option("--model", default=None, help="Vision model name (default $SIFTOM_VLM_MODEL, else $SIFTOM_LLM_MODEL).")
@click.option("--llm-base-url", default=None,
              help="OpenAI-compatible API root of the vision model, e.g. http://127.0.0.1:8080/v1 [env SIFTOM_LLM_BASE_URL].")
@click.option("--no-cache", is_flag=True, help="Ask the model even when an answer is cached.")
@click.option("--max-tokens", type=click.IntRange(256, 1_000_000), default=8192, show_default=True,
              help="The longest answer asked for (a 50-object scene graph is ~6k tokens).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@pass_options(PerceiveFlags)
def perceive_cmd(args: PerceiveFlags) -> None:
    """Turn camera FRAMES (in time order) into a world and the person's actions with a vision model."""
    from siftom.errors import PerceptionError
    from siftom.perception import Frame, VisionModel, perceive

    images = [Frame.from_path(f) for f in args.frames]
    world = None
    if args.world_file is not None:
        from siftom.perception.pipeline import KnownWorld
        from siftom.safejson import loads, read_text

        raw = loads(read_text(args.world_file, "world file", PerceptionError), f"world file {args.world_file!r}",
                    PerceptionError)
        if not isinstance(raw, dict):
            raise PerceptionError(f"{args.world_file}: a world must be a JSON object")
        world = KnownWorld.from_json(raw)
    result = perceive(images, world=world, goal_space=args.goal_space, target=args.target,
                      propose_goals=not args.no_goals,
                      model=VisionModel(model=args.model, use_cache=not args.no_cache, base_url=args.llm_base_url,
                                        max_tokens=args.max_tokens))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result.world, indent=1) + "\n", encoding="utf-8")
    args.actions_out.parent.mkdir(parents=True, exist_ok=True)
    args.actions_out.write_text("".join(a + "\n" for a in result.actions), encoding="utf-8")
    if args.graph_out is not None and result.graph is not None:
        args.graph_out.write_text(json.dumps(result.graph.to_json(), indent=1) + "\n", encoding="utf-8")
    if args.as_json:
        click.echo(json.dumps(result.to_json(), indent=2))
        return
    w = result.world
    click.echo(f"{len(images)} frames -> {len(w['places'])} places, {len(w['items'])} objects, "
               f"{len(result.actions)} actions, {len(w['goals'])} goals ({len(result.proposed_goals)} proposed) "
               f"on {result.target}; {result.requests} model requests, {result.cache_hits} cached")
    click.echo(f"world: {args.out}   actions: {args.actions_out}")
    click.echo(f"next: siftom infer --scene {args.out} --actions {args.actions_out} --transcript \"...\"")


def register(root: click.Group) -> None:
    root.add_command(perceive_cmd)
