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

import difflib
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from siftom.errors import ObservationError, SceneGraphError, SiftomError
from siftom.safejson import loads, read_text
from siftom.world.model import NOTHING, Goal, Item, Place, State, World

MAX_BYTES = 20 * 1024 * 1024


@dataclass(frozen=True)
class WorldBounds:
    """How large a world may be, checked by :func:`check_world_bounds` on the raw JSON before any
    work (the walking-cost table grows with the square of the places and doors, the likelihoods
    with the classes and the length of their names). docs/service.md lists them.

    Attributes:
        max_places: places of a world JSON (a state's open places are a 62-bit mask).
        max_doors: doors of a world JSON.
        max_items: objects of a world JSON (a server passes its own, ``--max-world-items``).
        max_classes: distinct object classes (the built-in scenarios have at most 42).
        max_class_chars: letters of an object class or of one of its spoken names.
        max_name_chars: letters of a place, room or object name, a target or a verb.
        max_spoken_names: spoken names of one class in ``names``.
        max_goals: goals of the world's own library (the kitchen library has 151 recipes).
        max_goal_classes: classes one goal counts.
        max_nodes: nodes of a VirtualHome scene graph (the apartment graphs have about 360).
        max_edges: edges of a VirtualHome scene graph (the apartment graphs have about 630).
    """

    max_places: int = 62
    max_doors: int = 64
    max_items: int = 200
    max_classes: int = 64
    max_class_chars: int = 60
    max_name_chars: int = 100
    max_spoken_names: int = 20
    max_goals: int = 5000
    max_goal_classes: int = 20
    max_nodes: int = 5000
    max_edges: int = 20000


WORLD_BOUNDS = WorldBounds()


class WorldTooLargeError(ObservationError):
    """A world over one of the :class:`WorldBounds`: ``limit`` names it, ``value`` is the world's."""

    def __init__(self, what: str, value: int, limit: str, most: int, fix: str) -> None:
        super().__init__(f"the world has {what} {value}, more than the {most} allowed ({limit}); {fix}")
        self.limit, self.value, self.most = limit, value, most


def check_world_bounds(obj: Any, bounds: WorldBounds = WORLD_BOUNDS, max_items: int | None = None) -> None:
    """Refuse a world over ``bounds`` (``max_items`` overrides ``bounds.max_items``) with a
    :class:`WorldTooLargeError` naming the limit and the world's value. One pass over the raw JSON
    (world JSON or VirtualHome scene graph), nothing built: run it before anything else. Values of
    the wrong type are left to the loader, which names them."""
    if not isinstance(obj, dict):
        return
    b = bounds

    def count(key: str, what: str, most: int, limit: str, fix: str) -> list[Any]:
        raw = obj.get(key)
        if not isinstance(raw, list | dict):
            return []
        if len(raw) > most:
            raise WorldTooLargeError(what, len(raw), limit, most, fix)
        return list(raw.values()) if isinstance(raw, dict) else raw

    def text(value: Any, what: str, most: int, limit: str) -> None:
        if isinstance(value, str) and len(value) > most:
            raise WorldTooLargeError(f"{what} of length", len(value), limit, most,
                                     f"shorten {value[:20]!r}... to at most {most} characters")

    for key in ("target", "verb"):
        text(obj.get(key), f"a {key}", b.max_name_chars, "max_name_chars")
    goals = count("goals", "goals:", b.max_goals, "max_goals", "send the goals the robot may be asked for")
    for g in goals:
        counts = g.get("counts") if isinstance(g, dict) else None
        if isinstance(counts, dict):
            if len(counts) > b.max_goal_classes:
                raise WorldTooLargeError("a goal counting classes:", len(counts), "max_goal_classes",
                                         b.max_goal_classes, "split the goal")
            for c in counts:
                text(c, "a goal class", b.max_class_chars, "max_class_chars")
        if isinstance(g, dict):
            text(g.get("name"), "a goal name", b.max_name_chars, "max_name_chars")
    if "nodes" in obj and "edges" in obj:  # a VirtualHome scene graph
        count("nodes", "nodes:", b.max_nodes, "max_nodes", "leave out nodes the robot never uses")
        count("edges", "edges:", b.max_edges, "max_edges", "leave out edges of nodes the robot never uses")
        return
    places = count("places", "places:", b.max_places, "max_places",
                   "leave out places no object is at and nobody walks to")
    for p in places:
        if isinstance(p, dict):
            text(p.get("name"), "a place name", b.max_name_chars, "max_name_chars")
            text(p.get("room"), "a room name", b.max_name_chars, "max_name_chars")
            text(p.get("kind"), "a place kind", b.max_name_chars, "max_name_chars")
    doors = count("doors", "doors:", b.max_doors, "max_doors", "keep the doors between rooms the robot uses")
    for d in doors:
        rooms = d.get("rooms") if isinstance(d, dict) else None
        if isinstance(rooms, list):
            if len(rooms) > 2:
                return  # the loader names the mistake
            for r in rooms:
                text(r, "a room name", b.max_name_chars, "max_name_chars")
    most_items = b.max_items if max_items is None else max_items
    items = count("items", "objects:", most_items, "max_items" if max_items is None else "--max-world-items",
                  "leave out objects no goal mentions")
    classes: set[str] = set()
    for it in items:
        if isinstance(it, dict):
            text(it.get("name"), "an object name", b.max_name_chars, "max_name_chars")
            text(it.get("at"), "a place name", b.max_name_chars, "max_name_chars")
            cls = it.get("class")
            text(cls, "an object class", b.max_class_chars, "max_class_chars")
            if isinstance(cls, str):
                classes.add(cls)
    if len(classes) > b.max_classes:
        raise WorldTooLargeError("object classes:", len(classes), "max_classes", b.max_classes,
                                 "leave out objects of classes no goal mentions")
    for said in count("names", "spoken names of classes:", b.max_classes, "max_classes",
                      "give names only for the world's classes"):
        said = [said] if isinstance(said, str) else said
        if isinstance(said, list):
            if len(said) > b.max_spoken_names:
                raise WorldTooLargeError("a class with spoken names:", len(said), "max_spoken_names",
                                         b.max_spoken_names, "keep the names people actually say")
            for x in said:
                text(x, "a spoken name", b.max_class_chars, "max_class_chars")
    for key in ("open",):
        count(key, "open places:", b.max_places, "max_places", "list each open place once")
    agents = obj.get("agents")
    if isinstance(agents, dict):
        if len(agents) > 2:
            return  # the loader names the mistake
        for v in agents.values():
            text(v, "a place name", b.max_name_chars, "max_name_chars")

# VirtualHome class names -> siftom object classes
VH_ALIASES = {
    "cutleryfork": "fork", "cutleryknife": "knife", "spoon": "spoon", "dishbowl": "bowl", "plate": "plate",
    "wineglass": "wineglass", "waterglass": "waterglass", "mug": "mug", "coffeecup": "cup", "cup": "cup",
    "milk": "milk", "cereal": "cereal", "bananas": "banana", "breadslice": "bread", "chicken": "chicken",
    "juice": "orange_juice", "chocolatesyrup": "syrup", "condimentshaker": "salt", "salmon": "salmon",
}


@dataclass(frozen=True, eq=False)
class LoadedScene:
    """A user scene: world, start state, goal space and the robot's verb."""

    world: World
    start: State
    goals: tuple[Goal, ...]
    verb: str
    notes: tuple[str, ...] = ()  # what the loader left out, and why (shown as warnings)


def _need(d: object, key: str, where: str) -> Any:
    if not isinstance(d, dict):
        raise ObservationError(f"{where} must be an object with {key!r}")
    if key not in d:
        raise ObservationError(f"{where}: missing {key!r}")
    return d[key]


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
    goals = feasible_goals(obj, world, target)
    verb = str(obj.get("verb", "fetch" if obj.get("goal_space") == "kitchen-v0" else "deliver"))
    return LoadedScene(world, start, goals, verb)


_NAME_RE = re.compile(r"^[a-z][a-z' ]*[a-z]$|^[a-z]$")


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


def goal_library(obj: dict[str, Any], target: int) -> list[Goal]:
    """Every goal of the library a world names (its own ``goals`` or a ``goal_space``), unfiltered."""
    if "goals" in obj:
        goals = []
        raw = obj["goals"]
        if not isinstance(raw, list) or not raw:
            raise ObservationError("goals must be a non-empty list like [{\"name\": \"salad\", \"counts\": {\"tomato\": 1}}]")
        for k, g in enumerate(raw):
            if not isinstance(g, dict):
                raise ObservationError(f"goals[{k}] must be an object with name and counts")
            counts = _need(g, "counts", f"goals[{k}]")
            if not isinstance(counts, dict) or not counts:
                raise ObservationError(f"goals[{k}]: counts must be an object like {{\"fork\": 2}}")
            if not all(isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 20 for n in counts.values()):
                raise ObservationError(f"goals[{k}]: each count must be an integer from 1 to 20")
            goals.append(Goal(str(g.get("name", f"goal{k}")), target, tuple(sorted((str(c), int(n)) for c, n in counts.items()))))
        return goals
    space = obj.get("goal_space", "household-table-v0")
    if space == "household-table-v0":
        from siftom.world.domains.household import goal_space
    elif space == "kitchen-v0":
        from siftom.world.domains.kitchen import goal_space
    else:
        raise ObservationError(f"goal_space must be household-table-v0 or kitchen-v0, got {space!r}; or give 'goals'")
    return [Goal(g.name, target, g.counts) for g in goal_space(target)]


def feasible_goals(obj: dict[str, Any], world: World, target: int) -> tuple[Goal, ...]:
    """The goals of the library ``obj`` names that the world's objects can satisfy (none: an error)."""
    have = Counter(it.cls for it in world.items)
    goals = goal_library(obj, target)
    feasible = [g for g in goals if all(have[c] >= n for c, n in g.counts)]
    if not feasible:
        raise ObservationError("no goal in the goal space can be reached with the objects in this scene"
                               + _why_unreachable(goals, world))
    return tuple(feasible)


def _why_unreachable(goals: list[Goal], world: World, show: int = 3) -> str:
    """What the first goals lack, with the scene's closest class names for a misspelt one."""
    have = Counter(it.cls for it in world.items)
    parts = []
    for g in goals[:show]:
        lacks = []
        for c, n in g.counts:
            if have[c] >= n:
                continue
            close = difflib.get_close_matches(c, list(have), n=2, cutoff=0.7) if have[c] == 0 else []
            hint = f" (did you mean {' or '.join(repr(x) for x in close)}?)" if close else ""
            lacks.append(f"{n} {c} (the scene has {have[c]}){hint}")
        parts.append(f"{g.name!r} needs {', '.join(lacks)}")
    more = f"; and {len(goals) - show} more goals" if len(goals) > show else ""
    return ": " + "; ".join(parts) + more


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
        lib = goal_library({"goal_space": space}, scene.goals[0].target)
    else:
        lib = goal_library(obj, scene.goals[0].target)
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


def scene_from_scenegraph(graph: Any, target: str | None = None, goal_space: str = "household-table-v0",
                          max_places: int = 40, goals: list[Any] | None = None) -> LoadedScene:
    """Turn a VirtualHome graph into a world: furniture holding known objects become places.

    Objects are kept when their class (or its alias in ``VH_ALIASES``) is used by a goal of
    ``goal_space``, or of ``goals`` (a world JSON's goal list, e.g. a ``"goals"`` key added to the
    graph file). What is left out is listed in the scene's ``notes``, never dropped silently.

    Positions are bounding-box centres projected on the floor (x, z); with no doors in the
    graph, walking cost is the straight-line distance (docs/world.md).
    """
    from siftom.world.scenegraph import SymbolicScene

    view = SymbolicScene.of(graph)
    tnode = None
    want = target or ("kitchentable" if goal_space == "household-table-v0" else "kitchencounter")
    for nid in view.surfaces:
        node = graph.node(nid)
        if node.class_name == want or node.label == want:
            tnode = nid
            break
    if tnode is None:
        raise SceneGraphError(f"no surface named {want!r} to use as the target; pass target=CLASS_NAME")
    spec: dict[str, Any] = {"goals": goals} if goals is not None else {"goal_space": goal_space}
    known = {c for g in goal_library(spec, 0) for c, _n in g.counts}
    objs: list[Any] = []
    unknown: Counter[str] = Counter()
    loose: Counter[str] = Counter()
    lib = "given" if goals is not None else goal_space
    why: dict[int, str] = {}  # graph node id -> why it is not in the world
    for nid in view.grabbables:
        vh_cls = graph.node(nid).class_name
        cls = VH_ALIASES.get(vh_cls) or (vh_cls if vh_cls in known else None)
        pl = view.placement(nid)
        parent = pl.parent if pl is not None else None
        seen = set()
        while parent is not None and view.is_grabbable(parent) and parent not in seen:  # stacked objects
            seen.add(parent)
            up = view.placement(parent)
            parent = up.parent if up is not None else None
        if cls is None:
            unknown[vh_cls] += 1
            why[nid] = f"no {lib} goal uses class {vh_cls!r} (add a goal that mentions it)"
        elif parent is None:
            loose[vh_cls] += 1
            why[nid] = "it rests on no furniture in the graph (give it an ON or INSIDE edge)"
        else:
            objs.append((nid, cls, parent))
    holders = sorted({p for _n, _c, p in objs} - {tnode})
    parents = sorted([tnode] + holders[:max_places - 1])
    notes = _left_out_notes(lib, unknown, loose, holders[max_places - 1:], objs)
    for nid, _c, parent in objs:
        if parent not in parents:
            why[nid] = f"its furniture is beyond the first {max_places} places kept (raise max_places)"
    for node in graph.nodes:
        if node.id not in why and node.id not in parents and not view.is_grabbable(node.id):
            why[node.id] = "it holds no object a goal uses, so it is not a place of this world"
    objs = [o for o in objs if o[2] in set(parents)]
    places: list[Any] = []
    pidx: dict[Any, int] = {}
    for nid in parents:
        node = graph.node(nid)
        pos = view.position(nid) or (0.0, 0.0, 0.0)
        cont = view.container(nid)
        room = view.room_of(nid)
        rname = next((r.name for r in view.rooms if r.id == room), "room")
        pidx[nid] = len(places)
        places.append(Place(node.label, "container" if cont is not None and cont.openable else "surface", rname,
                            (float(pos[0]), float(pos[2])), closable=bool(cont is not None and cont.openable),
                            node_id=nid))
    dist = World.distances_from_positions(places)
    items, item_at = [], []
    for nid, cls, parent in objs:
        if parent in pidx:
            items.append(Item(graph.node(nid).label, cls, node_id=nid))
            item_at.append(pidx[parent])
    world = World(tuple(places), tuple(items), dist, left_out=why)
    open_mask = 0
    for nid, i in pidx.items():
        c = view.container(nid)
        if c is not None and c.openable and c.is_open:
            open_mask |= 1 << i
    t = pidx[tnode]
    start = State((t, t), (NOTHING, NOTHING), tuple(item_at), open_mask)
    try:
        feasible = feasible_goals(spec, world, t)
    except ObservationError as exc:  # e.g. every class unknown: what was left out is the answer
        raise ObservationError("; ".join([str(exc), *notes])) from None
    return LoadedScene(world, start, feasible, "fetch" if goal_space == "kitchen-v0" else "deliver", notes)


def _summary(counts: Counter[str], limit: int = 8) -> str:
    items = [f"{c} x{n}" if n > 1 else c for c, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))]
    more = f" and {len(items) - limit} more classes" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more


def _left_out_notes(goal_space: str, unknown: Counter[str], loose: Counter[str], dropped_places: list[int],
                    objs: list[tuple[int, str, int]]) -> tuple[str, ...]:
    """Say what a VirtualHome graph had that the world leaves out, so nothing vanishes silently."""
    notes = []
    if unknown:
        notes.append(f"left out {sum(unknown.values())} grabbable objects whose class no {goal_space} goal uses "
                     f"({_summary(unknown)}); to use them, add a 'goals' list to the graph JSON "
                     "(as in a world JSON: [{\"name\": ..., \"counts\": {CLASS: N}}]) that mentions them")
    if loose:
        notes.append(f"left out {sum(loose.values())} objects that rest on no furniture in the graph "
                     f"({_summary(loose)}); give them an ON or INSIDE edge to a surface or container")
    if dropped_places:
        gone = set(dropped_places)
        lost = Counter(cls for _n, cls, p in objs if p in gone)
        notes.append(f"kept the first places by node id and left out {len(gone)} more holding "
                     f"{sum(lost.values())} objects ({_summary(lost)}); raise max_places to keep them")
    return tuple(notes)
