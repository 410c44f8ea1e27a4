"""Bring your own scene: siftom's world JSON and VirtualHome scene graphs -> World + State.

World JSON (docs/world.md has the full schema, every field and its default, and a runnable
example in docs/examples/salad/)::

    {"places": [{"name": "table", "kind": "surface", "room": "dining", "pos": [0, 0]},
                {"name": "drawer", "kind": "container", "room": "kitchen", "pos": [5, 1], "closable": true}],
     "doors": [{"rooms": ["dining", "kitchen"], "pos": [2, 0]}],
     "items": [{"name": "fork_1", "class": "fork", "at": "drawer"}],
     "agents": {"human": "table", "robot": "table"},
     "open": ["drawer"],
     "target": "table",
     "verb": "deliver",
     "goals": [{"name": "forks", "counts": {"fork": 2}}]}

Instead of ``goals`` a file may say ``"goal_space": "household-table-v0"`` (every 2-3 type
subset, 2-4 of each) or ``"kitchen-v0"`` (the recipe library).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from siftom.errors import ObservationError, SiftomError
from siftom.safejson import loads, read_text
from siftom.world.bounds import WORLD_BOUNDS as WORLD_BOUNDS
from siftom.world.bounds import WorldBounds as WorldBounds
from siftom.world.bounds import WorldTooLargeError as WorldTooLargeError
from siftom.world.bounds import check_world_bounds as check_world_bounds
from siftom.world.library import GoalSpec as GoalSpec
from siftom.world.library import LoadedScene as LoadedScene
from siftom.world.library import _need, goal_class_notes
from siftom.world.library import feasible_goals as feasible_goals
from siftom.world.library import goal_library as goal_library
from siftom.world.model import NOTHING, Goal, Item, Place, State, World
from siftom.world.vhscene import VH_ALIASES as VH_ALIASES
from siftom.world.vhscene import scene_from_scenegraph as scene_from_scenegraph

MAX_BYTES = 20 * 1024 * 1024


def scene_from_json(obj: Any) -> LoadedScene:
    """Build a scene from siftom's world JSON (see module docstring); clear errors on bad input."""
    try:
        return _scene_from_json(obj)
    except SiftomError:
        raise
    except (TypeError, ValueError, KeyError, AttributeError, IndexError, OverflowError, RecursionError) as exc:
        # a value of the wrong type somewhere the checks above do not look
        raise ObservationError(f"the world is malformed ({type(exc).__name__}: {str(exc)[:160]}); docs/world.md "
                               "gives the schema") from None


def _scene_from_json(obj: Any) -> LoadedScene:
    if not isinstance(obj, dict):
        raise ObservationError("a world file must be a JSON object with 'places', 'items' and 'target'")
    check_world_bounds(obj)  # before anything is built
    if "nodes" in obj and "edges" in obj:
        from siftom.world.scenegraph import SceneGraph

        return scene_from_scenegraph(SceneGraph.from_json(obj), target=obj.get("target"), goals=obj.get("goals"))
    raw_places = _need(obj, "places", "world")
    if not isinstance(raw_places, list) or not raw_places:
        raise ObservationError("world: 'places' must be a non-empty list")
    check_types(obj)  # every field's JSON type, named with its fix, before anything is built
    places = []
    for k, p in enumerate(raw_places):
        if not isinstance(p, dict):
            raise ObservationError(f"places[{k}] must be an object with name, kind, room, pos")
        pos = p.get("pos", [0.0, 0.0])
        if not (isinstance(pos, list) and len(pos) == 2 and all(isinstance(v, int | float) for v in pos)):
            raise ObservationError(f"places[{k}] ({p.get('name')}): pos must be [x, y] in metres")
        places.append(Place(str(_need(p, "name", f"places[{k}]")), str(p.get("kind", "surface")),
                            str(p.get("room", "room")), (float(pos[0]), float(pos[1])),
                            bool(p.get("closable", p.get("kind") == "container"))))
    doors = {}
    for k, d in enumerate(obj.get("doors", [])):
        rooms = _need(d, "rooms", f"doors[{k}]")
        pos = _need(d, "pos", f"doors[{k}]")
        if not (isinstance(rooms, list) and len(rooms) == 2):
            raise ObservationError(f"doors[{k}]: rooms must be a list of two room names")
        doors[frozenset(map(str, rooms))] = (float(pos[0]), float(pos[1]))
    dist = World.distances_from_positions(places, doors)
    items, item_at = [], []
    pidx = {p.name: i for i, p in enumerate(places)}

    def place_of(name: Any, where: str) -> int:
        if not isinstance(name, str) or name not in pidx:
            from siftom.errors import unknown_name

            raise ObservationError(f"{where}: {unknown_name('place', str(name), pidx)}")
        return pidx[name]

    for k, it in enumerate(_need(obj, "items", "world")):
        items.append(Item(str(_need(it, "name", f"items[{k}]")), str(_need(it, "class", f"items[{k}]"))))
        item_at.append(place_of(_need(it, "at", f"items[{k}]"), f"items[{k}]"))
    names = spoken_names(obj.get("names"), {it.cls for it in items})
    unspeakable = sorted({it.cls for it in items} - {c for c, _ in names}
                         - {c for c in (it.cls for it in items) if _NAME_RE.match(c.replace("_", " "))})
    if unspeakable:
        c = unspeakable[0]
        raise ObservationError(f"object class {c!r} cannot be said as it is written (a spoken name is lowercase "
                               f"words); give it the names people say in \"names\", e.g. \"names\": "
                               f"{{\"{c}\": [\"blue mug\"]}} (docs/world.md)")
    world = World(tuple(places), tuple(items), dist, names=names)
    agents = obj.get("agents", {})
    human = place_of(agents.get("human", places[0].name), "agents.human")
    robot = place_of(agents.get("robot", places[0].name), "agents.robot")
    open_mask = 0
    for name in obj.get("open", []):
        open_mask |= 1 << place_of(name, "open")
    target = place_of(_need(obj, "target", "world"), "target")
    start = State((human, robot), (NOTHING, NOTHING), tuple(item_at), open_mask)
    spec = GoalSpec.from_json(obj)
    goals = feasible_goals(spec, world, target)
    verb = str(obj.get("verb", "fetch" if obj.get("goal_space") == "kitchen-v0" else "deliver"))
    return LoadedScene(world, start, goals, verb, notes=goal_class_notes(spec, world, target))


_NAME_RE = re.compile(r"^[a-z][a-z' ]*[a-z]$|^[a-z]$")

_PLACE_EG = '{"name": "fridge", "kind": "container", "room": "kitchen", "pos": [5, 1]}'
_ITEM_EG = '{"name": "milk_1", "class": "milk", "at": "fridge"}'
_DOOR_EG = '{"rooms": ["kitchen", "dining"], "pos": [2, 0]}'


def _json_type(v: Any) -> str:
    """``v``'s JSON type, as a message names it."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true/false"
    if isinstance(v, int | float):
        return f"the number {v!r}"[:40]
    if isinstance(v, str):
        return f"the text {v[:30]!r}"
    return "a list" if isinstance(v, list) else "an object" if isinstance(v, dict) else type(v).__name__


def _wrong(where: str, want: str, got: Any, example: str) -> ObservationError:
    return ObservationError(f"{where} must be {want}, got {_json_type(got)}; e.g. {example} (docs/world.md)")


def _text(v: Any, where: str, example: str, required: bool = True) -> None:
    if v is None and not required:
        return
    if not isinstance(v, str) or not v.strip():
        raise _wrong(where, "a name (text)", v, example)


def _named(d: dict[str, Any], key: str, where: str, example: str) -> None:
    """``d[key]`` is there and is a name (text)."""
    if key not in d:
        raise ObservationError(f"{where}: missing {key!r}; e.g. {example} (docs/world.md)")
    _text(d[key], f"{where}.{key}", example)


def _xy(v: Any, where: str, example: str) -> None:
    if not (isinstance(v, list) and len(v) == 2
            and all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)):
        raise _wrong(where, "[x, y] in metres (two numbers)", v, example)


def _list(v: Any, where: str, example: str) -> list[Any]:
    if not isinstance(v, list):
        raise _wrong(where, "a list", v, example)
    return v


def _obj(v: Any, where: str, example: str) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise _wrong(where, "an object", v, example)
    return v


def check_types(obj: dict[str, Any]) -> None:
    """Refuse a world JSON field of the wrong JSON type, naming the field and the fix (a list
    where a name goes, ``"open": "fridge"`` for ``["fridge"]``), before anything reads it."""
    for k, p in enumerate(_list(obj["places"], "places", f"[{_PLACE_EG}]")):
        p = _obj(p, f"places[{k}]", _PLACE_EG)
        _named(p, "name", f"places[{k}]", '"fridge"')
        for key, eg in (("kind", '"container"'), ("room", '"kitchen"')):
            _text(p.get(key), f"places[{k}].{key}", eg, required=False)
        if "pos" in p:
            _xy(p["pos"], f"places[{k}].pos", "[5, 1]")
        if "closable" in p and not isinstance(p["closable"], bool):
            raise _wrong(f"places[{k}].closable", "true or false", p["closable"], "true")
    for k, d in enumerate(_list(obj.get("doors", []), "doors", f"[{_DOOR_EG}]")):
        d = _obj(d, f"doors[{k}]", _DOOR_EG)
        rooms = _need(d, "rooms", f"doors[{k}]")
        if not (isinstance(rooms, list) and len(rooms) == 2 and all(isinstance(r, str) and r for r in rooms)):
            raise _wrong(f"doors[{k}].rooms", "a list of two room names", rooms, '["kitchen", "dining"]')
        _xy(_need(d, "pos", f"doors[{k}]"), f"doors[{k}].pos", "[2, 0]")
    for k, it in enumerate(_list(_need(obj, "items", "world"), "items", f"[{_ITEM_EG}]")):
        it = _obj(it, f"items[{k}]", _ITEM_EG)
        for key, eg in (("name", '"milk_1"'), ("class", '"milk"'), ("at", '"fridge"')):
            _named(it, key, f"items[{k}]", eg)
    agents = _obj(obj.get("agents", {}), "agents", '{"human": "counter", "robot": "counter"}')
    for who in ("human", "robot"):
        _text(agents.get(who), f"agents.{who}", '"counter"', required=False)
    for k, name in enumerate(_list(obj.get("open", []), "open", '["fridge"] (a list of place names)')):
        _text(name, f"open[{k}]", '"fridge"')
    _text(obj.get("target"), "target", '"table" (the place the goal objects go to)', required=False)
    for key, eg in (("verb", '"deliver" or "fetch"'), ("goal_space", '"household-table-v0" or "kitchen-v0"')):
        _text(obj.get(key), key, eg, required=False)
    goals = obj.get("goals")
    if isinstance(goals, list):
        for k, g in enumerate(goals):
            if isinstance(g, dict):
                _text(g.get("name"), f"goals[{k}].name", '"salad"', required=False)


def spoken_names(raw: Any, classes: set[str]) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """A world's ``names``: ``{"coffee": ["iced coffee", "ice coffee"], "mug2": "blue mug"}``, each
    class of the world with the names people say for it, preferred first (checked; sorted by class)."""
    if raw is None:
        return ()
    if not isinstance(raw, dict):
        raise ObservationError('names must map an object class to its spoken names, e.g. '
                               '{"coffee": ["iced coffee", "ice coffee"]}')
    out = []
    for cls, v in raw.items():
        if cls not in classes:
            from siftom.errors import unknown_name

            raise ObservationError(f"names: {unknown_name('object class of this world', str(cls), sorted(classes))}")
        said = [v] if isinstance(v, str) else v
        if not isinstance(said, list) or not said or not all(isinstance(x, str) for x in said):
            raise ObservationError(f"names.{cls} must be a name or a non-empty list of names, e.g. [\"iced coffee\"]")
        clean = [" ".join(x.lower().split()) for x in said]
        bad = [x for x in clean if not _NAME_RE.match(x)]
        if bad:
            raise ObservationError(f"names.{cls}: {bad[0]!r} must be words of letters (and apostrophes) separated "
                                   "by spaces, e.g. 'iced coffee'; write numbers as words")
        out.append((str(cls), tuple(dict.fromkeys(clean))))
    return tuple(sorted(out))


def unmentioned_class_warnings(world: World, library: list[Goal] | tuple[Goal, ...]) -> list[str]:
    """One warning per object class of ``world`` that no goal of ``library`` mentions.

    Such objects can never be part of the robot's command (the goal prior gives them nothing);
    usually a class name is spelled differently from the library's. Each warning names the
    nearest library classes (difflib ratio), e.g. ``"cutleryfork" -> fork``.
    """
    import difflib

    known = sorted({c for g in library for c, _n in g.counts})
    out = []
    for cls in world.classes:
        if cls in known:
            continue
        near = [k for k in known if k in cls or cls in k]  # "cutleryfork" ~ "fork"
        near += [k for k in difflib.get_close_matches(cls, known, n=3, cutoff=0.0) if k not in near]
        hint = f"nearest goal-library classes: {', '.join(near[:3])}" if near else "the goal library is empty"
        out.append(f"objects of class {cls!r} appear in no goal, so the robot will never be asked for them; "
                   f"{hint} (rename the class, or add a goal that mentions it)")
    return out


def scene_warnings(obj: Any, scene: LoadedScene) -> list[str]:
    """Warnings about a loaded world JSON (classes no goal mentions)."""
    if not isinstance(obj, dict) or ("nodes" in obj and "edges" in obj and "goals" not in obj):
        space = obj.get("goal_space", "household-table-v0") if isinstance(obj, dict) else "household-table-v0"
        lib = goal_library(GoalSpec(space), scene.goals[0].target)
    else:
        lib = goal_library(GoalSpec.from_json(obj), scene.goals[0].target)
    return [*scene.notes, *unmentioned_class_warnings(scene.world, lib)]


def scene_to_json(world: World, start: State, goals: tuple[Goal, ...] | list[Goal], verb: str,
                  doors: dict[frozenset[str], tuple[float, float]] | None = None) -> dict[str, Any]:
    """The world JSON of a scene (inverse of :func:`scene_from_json`). Walking costs are recomputed
    from positions and ``doors`` (e.g. a built-in domain's ``DOORS``) when the JSON is loaded."""
    from siftom.world.model import HELD

    if any(h != NOTHING for h in start.held) or any(loc == HELD for loc in start.item_at):
        raise ObservationError("scene_to_json needs a start state where nobody holds anything")
    target = goals[0].target
    return {
        "places": [{"name": p.name, "kind": p.kind, "room": p.room, "pos": list(p.pos), "closable": p.closable}
                   for p in world.places],
        "doors": [{"rooms": sorted(rooms), "pos": list(pos)} for rooms, pos in (doors or {}).items()],
        "items": [{"name": it.name, "class": it.cls, "at": world.places[start.item_at[i]].name}
                  for i, it in enumerate(world.items)],
        "agents": {"human": world.places[start.agent_at[0]].name, "robot": world.places[start.agent_at[1]].name},
        "open": [p.name for i, p in enumerate(world.places) if p.closable and start.is_open(i)],
        "target": world.places[target].name,
        "verb": verb,
        "goals": [{"name": g.name, "counts": dict(g.counts)} for g in goals],
        **({"names": {cls: list(said) for cls, said in world.names}} if world.names else {}),
    }


def load_scene(path: str | Path, goal_space: str | None = None, target: str | None = None) -> LoadedScene:
    """Load a world JSON or a VirtualHome scene graph file."""
    p = Path(path)
    if not p.is_file():
        raise ObservationError(f"{p}: no such file; give a world JSON or a VirtualHome graph")
    if p.stat().st_size > MAX_BYTES:
        raise ObservationError(f"{p}: file is larger than {MAX_BYTES // 2**20} MB")
    obj = loads(read_text(p, "world file"), f"world file {str(p)!r}")
    check_world_bounds(obj)
    if isinstance(obj, dict) and "nodes" in obj and "edges" in obj:
        from siftom.world.scenegraph import SceneGraph

        return scene_from_scenegraph(SceneGraph.from_json(obj), target=target or obj.get("target"),
                                     goal_space=goal_space or "household-table-v0", goals=obj.get("goals"))
    if goal_space and isinstance(obj, dict) and "goals" not in obj:
        obj = {**obj, "goal_space": goal_space}
    return scene_from_json(obj)
