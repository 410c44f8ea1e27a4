"""How large a world may be: :class:`WorldBounds`, checked on the raw JSON before any work."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from siftom.errors import ObservationError


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
    for key in ("target", "verb"):
        _text(obj.get(key), f"a {key}", b.max_name_chars, "max_name_chars")
    _check_goals(obj, b)
    if "nodes" in obj and "edges" in obj:  # a VirtualHome scene graph
        _count(obj, "nodes", "nodes:", b.max_nodes, "max_nodes", "leave out nodes the robot never uses")
        _count(obj, "edges", "edges:", b.max_edges, "max_edges", "leave out edges of nodes the robot never uses")
        return
    if not _check_layout(obj, b):
        return  # the loader names the mistake
    _check_items(obj, b, max_items)
    for said in _count(obj, "names", "spoken names of classes:", b.max_classes, "max_classes",
                       "give names only for the world's classes"):
        said = [said] if isinstance(said, str) else said
        if isinstance(said, list):
            if len(said) > b.max_spoken_names:
                raise WorldTooLargeError("a class with spoken names:", len(said), "max_spoken_names",
                                         b.max_spoken_names, "keep the names people actually say")
            for x in said:
                _text(x, "a spoken name", b.max_class_chars, "max_class_chars")
    _count(obj, "open", "open places:", b.max_places, "max_places", "list each open place once")
    agents = obj.get("agents")
    if isinstance(agents, dict):
        if len(agents) > 2:
            return  # the loader names the mistake
        for v in agents.values():
            _text(v, "a place name", b.max_name_chars, "max_name_chars")


def _count(obj: dict[str, Any], key: str, what: str, most: int, limit: str, fix: str) -> list[Any]:
    """The entries of the list (or the values of the object) at ``key``, refused over ``most``."""
    raw = obj.get(key)
    if not isinstance(raw, list | dict):
        return []
    if len(raw) > most:
        raise WorldTooLargeError(what, len(raw), limit, most, fix)
    return list(raw.values()) if isinstance(raw, dict) else raw


def _text(value: Any, what: str, most: int, limit: str) -> None:
    if isinstance(value, str) and len(value) > most:
        raise WorldTooLargeError(f"{what} of length", len(value), limit, most,
                                 f"shorten {value[:20]!r}... to at most {most} characters")


def _check_goals(obj: dict[str, Any], b: WorldBounds) -> None:
    goals = _count(obj, "goals", "goals:", b.max_goals, "max_goals", "send the goals the robot may be asked for")
    for g in goals:
        counts = g.get("counts") if isinstance(g, dict) else None
        if isinstance(counts, dict):
            if len(counts) > b.max_goal_classes:
                raise WorldTooLargeError("a goal counting classes:", len(counts), "max_goal_classes",
                                         b.max_goal_classes, "split the goal")
            for c in counts:
                _text(c, "a goal class", b.max_class_chars, "max_class_chars")
        if isinstance(g, dict):
            _text(g.get("name"), "a goal name", b.max_name_chars, "max_name_chars")


def _check_layout(obj: dict[str, Any], b: WorldBounds) -> bool:
    """Places and doors; False where a door names more than two rooms (the loader names that)."""
    places = _count(obj, "places", "places:", b.max_places, "max_places",
                    "leave out places no object is at and nobody walks to")
    for p in places:
        if isinstance(p, dict):
            _text(p.get("name"), "a place name", b.max_name_chars, "max_name_chars")
            _text(p.get("room"), "a room name", b.max_name_chars, "max_name_chars")
            _text(p.get("kind"), "a place kind", b.max_name_chars, "max_name_chars")
    doors = _count(obj, "doors", "doors:", b.max_doors, "max_doors", "keep the doors between rooms the robot uses")
    for d in doors:
        rooms = d.get("rooms") if isinstance(d, dict) else None
        if isinstance(rooms, list):
            if len(rooms) > 2:
                return False
            for r in rooms:
                _text(r, "a room name", b.max_name_chars, "max_name_chars")
    return True


def _check_items(obj: dict[str, Any], b: WorldBounds, max_items: int | None) -> None:
    """The objects, their names and places, and how many classes they make."""
    most_items = b.max_items if max_items is None else max_items
    items = _count(obj, "items", "objects:", most_items, "max_items" if max_items is None else "--max-world-items",
                   "leave out objects no goal mentions")
    classes: set[str] = set()
    for it in items:
        if isinstance(it, dict):
            _text(it.get("name"), "an object name", b.max_name_chars, "max_name_chars")
            _text(it.get("at"), "a place name", b.max_name_chars, "max_name_chars")
            cls = it.get("class")
            _text(cls, "an object class", b.max_class_chars, "max_class_chars")
            if isinstance(cls, str):
                classes.add(cls)
    if len(classes) > b.max_classes:
        raise WorldTooLargeError("object classes:", len(classes), "max_classes", b.max_classes,
                                 "leave out objects of classes no goal mentions")
