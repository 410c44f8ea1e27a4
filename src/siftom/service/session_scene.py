"""A session's record in memory (:class:`Session`) and the scene it is built over
(:func:`build_scene`: the robot's own world JSON or VirtualHome scene graph, and a goal library)."""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field, replace
from typing import Any

from pydantic import ValidationError

from siftom.errors import ObservationError, SiftomError
from siftom.inference.model import OnlineInference
from siftom.service.problems import ProblemError
from siftom.service.session_records import SessionOptions, SessionReply, SessionSpec
from siftom.world.io import (
    GoalSpec,
    LoadedScene,
    check_world_bounds,
    feasible_goals,
    goal_library,
    scene_from_json,
    unmentioned_class_warnings,
)

log = logging.getLogger("siftom.service")


@dataclass(eq=False)
class Session:
    """One live session (memory side)."""

    id: str
    created: float
    spec: SessionSpec
    options: SessionOptions
    scene: LoadedScene
    online: OnlineInference
    actions: list[str]
    warnings: list[str]
    last: SessionReply | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    belief: tuple[int, dict[str, Any]] | None = None  # (n_actions, belief) of the last view
    revision: int = 0  # answers stored (SessionManager.revision)


def build_scene(spec: SessionSpec, max_items: int) -> tuple[LoadedScene, list[str]]:
    """The session's scene from a create request's spec (world, goals, goal_space, target), and warnings."""
    world = spec.world
    check_world_bounds(world, max_items=max_items)  # before anything is built
    ignored = _ignored_goal_space(spec)
    try:
        if "nodes" in world and "edges" in world:
            from siftom.world.io import scene_from_scenegraph
            from siftom.world.scenegraph import SceneGraph

            space = (None if ignored else spec.goal_space) or world.get("goal_space") or "household-table-v0"
            goals = spec.goals or world.get("goals")
            scene = scene_from_scenegraph(SceneGraph.from_json(world), target=spec.target or world.get("target"),
                                          goal_space=space, goals=goals)
            lib_spec = GoalSpec(space, goals) if goals else GoalSpec(space)
        else:
            obj = dict(world)
            if spec.goal_space and not ignored:  # the world's own goals come first (docs/service.md)
                obj["goal_space"] = spec.goal_space
            if spec.target:
                obj["target"] = spec.target
            scene = scene_from_json(obj)
            lib_spec = GoalSpec.from_json(obj)
        if spec.goals:
            lib_spec = GoalSpec(goals=spec.goals)
            scene = replace(scene, goals=feasible_goals(lib_spec, scene.world, scene.goals[0].target))
    except SiftomError:
        raise
    except (TypeError, ValueError, KeyError, AttributeError, IndexError, OverflowError) as exc:
        raise ObservationError(f"the world is malformed ({type(exc).__name__}: {str(exc)[:200]}); "
                               "docs/world.md gives the schema") from None
    if len(scene.world.items) > max_items:
        raise ObservationError(f"the world holds {len(scene.world.items)} objects, more than the {max_items} "
                               "this server allows (--max-world-items); leave out objects no goal mentions")
    warnings = [*([ignored] if ignored else []), *scene.notes,
                *unmentioned_class_warnings(scene.world, goal_library(lib_spec, scene.goals[0].target))]
    return scene, warnings


def check_speakable(world: Any) -> None:
    """Every object class can be named in an instruction (the likelihoods match what was heard
    against the classes' names, the world's own ``names`` included): a 422 naming the first that
    cannot, with the fix."""
    import re

    from siftom.likelihood.lexicon import LexiconError, lexicon_for

    lex = lexicon_for(world)
    for c in world.classes:
        try:
            lex.entry(c)
        except LexiconError as exc:
            fix = re.sub(r"[^a-z_]+", "", c.lower()).strip("_") or "cup"
            raise ObservationError(f"class {c!r} has no spoken name, so no instruction could name it ({exc}); "
                                   f"give it the names people say in the world's \"names\" (e.g. \"names\": "
                                   f"{{\"{c}\": [\"blue mug\"]}}), or rename the class in the world to words, "
                                   f"letters and underscores only (e.g. {fix!r})") from None


def _ignored_goal_space(spec: SessionSpec) -> str | None:
    """The warning when a request's ``goal_space`` loses to its ``goals`` or the world's own goals."""
    space, world = spec.goal_space, spec.world
    if not space:
        return None
    if spec.goals:
        return f"goal_space {space!r} was ignored: the request's goals are used (goals come before goal_space)"
    if isinstance(world, dict) and world.get("goals"):
        return (f"goal_space {space!r} was ignored: the world lists its own goals, which come first; leave "
                "them out of the world (or send goals) to choose the library")
    return None


def unreadable(sid: str, exc: Exception) -> ProblemError:
    """A stored session that cannot be rebuilt: the server's 500 naming the session and the way out."""
    if isinstance(exc, ValidationError):
        errs = exc.errors()
        where = ".".join(str(p) for p in errs[0]["loc"]) if errs else ""
        reason = f"{where + ': ' if where else ''}{errs[0]['msg'] if errs else 'invalid'}"
    else:
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    log.error("stored session %s cannot be rebuilt: %s", sid, reason[:300])
    return ProblemError(500, "stored-session-unreadable",
                        f"session {sid!r} is stored but cannot be rebuilt ({reason[:200]}): its stored record was "
                        "changed outside siftom or no longer fits this server's settings; nothing in this request "
                        f"is wrong. DELETE /v1/sessions/{sid} and create the session again")
