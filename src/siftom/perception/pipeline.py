"""Frames -> world JSON, action log and goal space: the paper's VLM front end (Methods).

1. **Scene** (first frame): a VirtualHome scene graph, checked by
   :class:`~siftom.world.scenegraph.SceneGraph` and turned into siftom's world JSON
   (:mod:`siftom.perception.scene`). Skipped when a world is given.
2. **Actions** (each pair of consecutive frames): the person's actions in siftom's syntax,
   parsed and checked for legality in order from the state the earlier actions led to.
3. **Goals** (the last frame, the world and every action so far): proposed goals and the
   target place, checked against the world and merged with a domain's goal library.

The world JSON and the action log are exactly what ``siftom infer --scene W --actions A`` reads.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from siftom.errors import ObservationError, PerceptionError
from siftom.perception import prompts
from siftom.perception.frames import Frame
from siftom.perception.scene import parse_scene, scene_to_world
from siftom.perception.validate import (
    GoalProposal,
    NamedGoal,
    check_actions,
    check_goals,
    library_classes,
    library_goals,
    merge_goals,
)
from siftom.perception.vlm import VisionModel
from siftom.world.io import LoadedScene, scene_from_json
from siftom.world.model import State, World
from siftom.world.scenegraph import SceneGraph


@dataclass(frozen=True)
class PerceptionResult:
    """What the model saw.

    Attributes:
        world: siftom world JSON (``siftom infer --scene``), goals included.
        actions: the person's actions in order (``siftom infer --actions``).
        proposed_goals: the goals the model proposed (before merging with the library).
        target: the place the goals refer to.
        graph: the scene graph perceived in the first frame (None when a world was given).
        requests, cache_hits: questions sent to the model and answers read from the cache.
    """

    world: dict[str, Any]
    actions: tuple[str, ...]
    proposed_goals: tuple[NamedGoal, ...] = ()
    target: str = ""
    graph: SceneGraph | None = None
    requests: int = 0
    cache_hits: int = 0
    frames: tuple[str, ...] = field(default=())

    def to_json(self) -> dict[str, Any]:
        return {"world": self.world, "actions": list(self.actions), "proposed_goals": [g.to_json() for g in self.proposed_goals],
                "target": self.target, "graph": None if self.graph is None else self.graph.to_json(), "frames": list(self.frames),
                "requests": self.requests, "cache_hits": self.cache_hits,
                "num_objects": len(self.world.get("items", [])), "num_goals": len(self.world.get("goals", []))}


@dataclass(frozen=True)
class KnownWorld:
    """A world given with the frames (read by :meth:`from_json`).

    Attributes:
        world: siftom world JSON (``places``, ``items``, ...), target and goals possibly missing.
        goal_space: the goal library the given world names (None: none).
        target: the target place the given world names (None: none).
    """

    world: dict[str, Any]
    goal_space: str | None = None
    target: str | None = None

    @classmethod
    def from_json(cls, obj: Any) -> KnownWorld:
        """From siftom world JSON or a VirtualHome graph; PerceptionError when it is not valid."""
        if not isinstance(obj, dict):
            raise PerceptionError("a world must be a JSON object (siftom world JSON or a VirtualHome graph)")
        space = obj["goal_space"] if isinstance(obj.get("goal_space"), str) else None
        target = str(obj["target"]) if obj.get("target") else None
        return cls(_world_json(obj), space, target)

    def to_json(self) -> dict[str, Any]:
        return self.world


def _world_json(world: dict[str, Any]) -> dict[str, Any]:
    """World JSON (``places``, ``items``, ...) from a given world: siftom world JSON or a VirtualHome graph."""
    if "nodes" in world and "edges" in world:
        from siftom.errors import SceneGraphError
        from siftom.world.scenegraph import SceneGraph

        try:
            return scene_to_world(SceneGraph.from_json(world), strict=False).world
        except SceneGraphError as exc:
            raise PerceptionError(f"the given world is not a valid scene graph: {exc}") from None
    partial = dict(world)
    _load(partial)
    goals = partial.get("goals", [])
    if not isinstance(goals, list) or not all(
            isinstance(g, dict) and isinstance(g.get("name", ""), str) and isinstance(g.get("counts"), dict) and g["counts"]
            and all(isinstance(c, str) and isinstance(n, int) and not isinstance(n, bool) and n >= 1
                    for c, n in g["counts"].items()) for g in goals):
        raise PerceptionError('the world\'s goals must be a list like [{"name": "forks", "counts": {"fork": 2}}]')
    return partial


def _load(partial: dict[str, Any]) -> LoadedScene:
    """World and state from world JSON that may lack target and goals (filled in later)."""
    items = partial.get("items") or []
    if not isinstance(items, list) or not items or not isinstance(items[0], dict):
        raise PerceptionError("the world has no movable objects; a goal needs objects to gather")
    places = partial.get("places") or []
    first = places[0].get("name", "") if isinstance(places, list) and places and isinstance(places[0], dict) else ""
    stub = {"target": partial.get("target") or first,
            "goals": [{"name": "_", "counts": {str(items[0].get("class")): 1}}]}
    try:
        return scene_from_json({**partial, **stub})
    except (ObservationError, KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        # siftom's world reader expects well-formed JSON; a client's malformed world is a 422, not a crash
        raise PerceptionError(f"the world is not valid: {exc}") from None


def perceive_actions(world: World, state: State, frames: Sequence[Frame], model: VisionModel | None = None,
                     first: int = 1) -> tuple[list[str], State]:
    """The person's actions between consecutive frames, checked in order from ``state``.

    Returns the action strings (``World.parse_action`` syntax) and the state after them. For a
    robot that already knows its world (a session), this is the whole of perception.
    ``first`` numbers the frames in messages (``actions (frames 3 -> 4)``).
    """
    vlm = model or VisionModel()
    actions: list[str] = []
    s = state
    for k in range(1, len(frames)):
        prompt = prompts.actions_prompt(world, s)

        def check(answer: Any, before: State = s) -> tuple[list[str], State]:
            return answer["actions"], check_actions(world, before, answer["actions"])[1]

        stage = f"actions (frames {first + k - 1} -> {first + k})"
        texts, s = vlm.ask(stage, prompt, (frames[k - 1], frames[k]), "actions", check)
        actions.extend(texts)
    return actions, s


def perceive(
    frames: Sequence[Frame],
    *,
    world: KnownWorld | None = None,
    goal_space: str | None = None,
    target: str | None = None,
    propose_goals: bool = True,
    max_goals: int = 10,
    model: VisionModel | None = None,
) -> PerceptionResult:
    """Turn camera frames into a world, the person's actions and a goal space.

    Args:
        frames: one or more images in time order; the scene is read from the first one.
        world: a known world at the first frame (:meth:`KnownWorld.from_json` reads siftom
            world JSON or a VirtualHome graph); then only actions and goals are asked for.
        goal_space: a domain goal library to merge (``household-table-v0``, ``kitchen-v0``);
            its object names are also suggested to the model.
        target: the place goals refer to (default: the given world's, else the model's).
        propose_goals: ask the model for goals (the paper's VLM-proposed goal space).
        max_goals: at most this many proposals asked for.
        model: the vision model (default :class:`VisionModel` from the environment).
    """
    if not frames:
        raise PerceptionError("give at least one frame")
    if goal_space is None and world is not None:
        goal_space = world.goal_space  # a world that names its library keeps it
    library_names = library_classes(goal_space)  # also checks the name before any request
    vlm = model or VisionModel()
    graph = None
    if world is None:
        prompt = prompts.scene_prompt(library_names)
        perceived = vlm.ask("scene (frame 1)", prompt, frames[:1], "scene_graph", parse_scene)
        partial = perceived.world
        graph = perceived.graph
    else:
        partial = world.world
    scene = _load(partial)
    w, s = scene.world, scene.start
    actions, s = perceive_actions(w, s, frames, vlm)
    library = library_goals(w, goal_space)
    proposed: list[NamedGoal] = []
    where = target or (world.target if world is not None else None)
    if propose_goals:
        prompt = prompts.goals_prompt(w, s, actions, library, max_goals)
        model_target, proposed = vlm.ask("goals", prompt, frames[-1:], "goals",
                                     lambda a: check_goals(w, GoalProposal.from_json(a)))
        where = where or model_target
    if not where:
        raise PerceptionError("no target place: pass target= (--target PLACE) or let the model propose goals")
    if where not in {p.name for p in w.places}:
        from siftom.errors import unknown_name

        raise PerceptionError(f"target: {unknown_name('place', where, [p.name for p in w.places])}")
    given = [NamedGoal(str(g.get("name", f"goal{k}")), tuple(g["counts"].items()))
             for k, g in enumerate(partial.get("goals", []))]
    goals = merge_goals(proposed, merge_goals(given, library))
    if not goals:
        raise PerceptionError("no goal: the model proposed none and no goal library fits these objects; "
                              "pass --goal-space or give goals in the world")
    verb = "fetch" if goal_space == "kitchen-v0" else str(partial.get("verb", "deliver"))
    out = {k: v for k, v in partial.items() if k not in ("goal_space", "goals", "target", "verb")}
    out.update(target=where, verb=verb, goals=[g.to_json() for g in goals])
    try:
        scene_from_json(out)
    except ObservationError as exc:
        raise PerceptionError(f"the perceived world is not valid: {exc}") from None
    return PerceptionResult(out, tuple(actions), tuple(proposed), where, graph, vlm.requests, vlm.cache_hits,
                            tuple(f.name for f in frames))

