"""Scene-graph nodes and edges (VirtualHome schema), validated at construction."""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from siftom.errors import SceneGraphError

Vec3 = tuple[float, float, float]

MIB = 1024 * 1024
DEFAULT_MAX_BYTES = 50 * MIB
"""Largest scene-graph file :meth:`SceneGraph.load` reads by default (the real apartments are
about 0.2 MB; a graph ten times larger than any VirtualHome scene is still far below this)."""

ROOM_CATEGORY = "Rooms"

# The node keys this module understands; any other key is kept verbatim in Node.extra.
_NODE_KEYS = ("id", "category", "class_name", "prefab_name", "obj_transform", "bounding_box",
              "properties", "states")
_EDGE_KEYS = ("from_id", "relation_type", "to_id")


class Relation(StrEnum):
    """Edge relation types of the VirtualHome graph schema."""

    ON = "ON"
    INSIDE = "INSIDE"
    CLOSE = "CLOSE"
    FACING = "FACING"
    BETWEEN = "BETWEEN"
    HOLDS_RH = "HOLDS_RH"
    HOLDS_LH = "HOLDS_LH"
    SITTING = "SITTING"


_PLACEMENT = (Relation.INSIDE, Relation.ON)  # relations that say where an object is, in this order
_HOLDS_SEARCH_LIMIT = 512  # edges looked at when deciding which holder is the innermost


# --------------------------------------------------------------------------------------------
# Small validation helpers


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    return (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value))


def _type_name(value: object) -> str:
    return {dict: "an object", list: "a list", tuple: "a list", str: "a string", bool: "a boolean",
            int: "an integer", float: "a number", type(None): "null"}.get(type(value),
                                                                           type(value).__name__)


def _vec3(value: object, what: str) -> Vec3:
    if not isinstance(value, list | tuple) or len(value) != 3 or not all(map(_is_number, value)):
        raise SceneGraphError(f"{what} must be a list of 3 finite numbers [x, y, z], got "
                              f"{_short(value)}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _short(value: object, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


# --------------------------------------------------------------------------------------------
# Nodes and edges


@dataclass(frozen=True, slots=True)
class BoundingBox:
    """An axis-aligned box: ``center`` and ``size`` in metres (x, y, z; y is up)."""

    center: Vec3
    size: Vec3

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vec3(self.center, "bounding_box.center"))
        object.__setattr__(self, "size", _vec3(self.size, "bounding_box.size"))
        if any(s < 0 for s in self.size):
            raise SceneGraphError(f"bounding_box.size must not be negative, got {self.size}")

    @property
    def volume(self) -> float:
        """Volume in cubic metres."""
        return self.size[0] * self.size[1] * self.size[2]

    def contains(self, point: Vec3) -> bool:
        """Whether ``point`` lies inside the box (borders included)."""
        return all(abs(p - c) <= s / 2 for p, c, s in zip(point, self.center, self.size, strict=True))

    def to_json(self) -> dict[str, list[float]]:
        """The ``{"center": [...], "size": [...]}`` form of the schema."""
        return {"center": list(self.center), "size": list(self.size)}


@dataclass(frozen=True, slots=True)
class Node:
    """One object, piece of furniture, room or character of the scene."""

    id: int
    class_name: str
    category: str = ""
    properties: tuple[str, ...] = ()
    states: tuple[str, ...] = ()
    bounding_box: BoundingBox | None = None
    obj_transform: dict[str, Any] | None = field(default=None, hash=False)
    prefab_name: str | None = None
    extra: dict[str, Any] = field(default_factory=dict, hash=False, repr=False)
    """Keys of the JSON node this module does not interpret, kept so that saving loses nothing."""

    def __post_init__(self) -> None:
        if not _is_int(self.id):
            raise SceneGraphError(f"node id must be an integer, got {_short(self.id)}; "
                                  'write it as e.g. "id": 12')
        where = f"node {self.id}"
        if not isinstance(self.class_name, str) or not self.class_name:
            raise SceneGraphError(f"{where}: class_name must be a non-empty string, got "
                                  f"{_short(self.class_name)}; name its class, e.g. \"fridge\"")
        where = f"node {self.id} ({self.class_name!r})"
        if not isinstance(self.category, str):
            raise SceneGraphError(f"{where}: category must be a string, got {_short(self.category)}")
        for name in ("properties", "states"):
            value = getattr(self, name)
            if not isinstance(value, tuple) or not all(isinstance(v, str) for v in value):
                raise SceneGraphError(f"{where}: {name} must be a list of strings, got "
                                      f"{_short(value)}; e.g. [\"CAN_OPEN\", \"CONTAINERS\"]")
        if {"OPEN", "CLOSED"} <= set(self.states):
            raise SceneGraphError(f"{where}: states has both OPEN and CLOSED; keep the one that "
                                  "is true")
        if self.bounding_box is not None and not isinstance(self.bounding_box, BoundingBox):
            raise SceneGraphError(f"{where}: bounding_box must be a BoundingBox or None")
        if self.obj_transform is not None and not isinstance(self.obj_transform, dict):
            raise SceneGraphError(f"{where}: obj_transform must be an object or null, got "
                                  f"{_short(self.obj_transform)}")
        if self.prefab_name is not None and not isinstance(self.prefab_name, str):
            raise SceneGraphError(f"{where}: prefab_name must be a string or null, got "
                                  f"{_short(self.prefab_name)}")
        if not isinstance(self.extra, dict):
            raise SceneGraphError(f"{where}: extra must be a dict")

    @property
    def label(self) -> str:
        """``class_name.id``, e.g. ``fridge.165``: how messages and the CLI name a node."""
        return f"{self.class_name}.{self.id}"

    @property
    def is_room(self) -> bool:
        """Whether the node is a room (category ``Rooms``)."""
        return self.category == ROOM_CATEGORY

    @property
    def position(self) -> Vec3 | None:
        """The bounding-box centre, else ``obj_transform.position``, else None."""
        if self.bounding_box is not None:
            return self.bounding_box.center
        pos = (self.obj_transform or {}).get("position")
        if isinstance(pos, list | tuple) and len(pos) == 3 and all(map(_is_number, pos)):
            return (float(pos[0]), float(pos[1]), float(pos[2]))
        return None

    def has_property(self, name: str) -> bool:
        """Whether ``name`` (e.g. ``"GRABBABLE"``) is among the node's properties."""
        return name in self.properties

    @classmethod
    def from_json(cls, obj: object, index: int = 0) -> Node:
        """Build a node from its JSON object; ``index`` (its place in "nodes") is for messages."""
        if not isinstance(obj, dict):
            raise SceneGraphError(f"nodes[{index}] must be an object, got {_type_name(obj)}")
        hint = f" (class_name {obj['class_name']!r})" if isinstance(obj.get("class_name"), str) else ""
        if "id" not in obj:
            raise SceneGraphError(f"nodes[{index}]{hint} has no 'id'; give every node a unique "
                                  "integer id")
        node_id = obj["id"]
        if not _is_int(node_id):
            raise SceneGraphError(f"nodes[{index}]{hint} has a non-integer id {_short(node_id)}; "
                                  'ids must be integers, e.g. "id": 12')
        if "class_name" not in obj:
            raise SceneGraphError(f"node {node_id} (nodes[{index}]) has no 'class_name'; add one, "
                                  'e.g. "class_name": "fridge"')
        where = f"node {node_id}{hint}"
        lists = {}
        for name in ("properties", "states"):
            value = obj.get(name, [])
            if value is None:
                value = []
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise SceneGraphError(f"{where}: {name} must be a list of strings, got "
                                      f"{_short(value)}; e.g. [\"CAN_OPEN\", \"CONTAINERS\"]")
            lists[name] = tuple(value)
        box = obj.get("bounding_box")
        if box is not None:
            if not isinstance(box, dict) or "center" not in box or "size" not in box:
                raise SceneGraphError(f"{where}: bounding_box must be an object with 'center' and "
                                      f"'size' lists of 3 numbers, or null; got {_short(box)}")
            try:
                box = BoundingBox(box["center"], box["size"])
            except SceneGraphError as exc:
                raise SceneGraphError(f"{where}: {exc}") from None
        return cls(
            id=node_id,
            class_name=obj["class_name"],
            category=obj.get("category", ""),
            properties=lists["properties"],
            states=lists["states"],
            bounding_box=box,
            obj_transform=obj.get("obj_transform"),
            prefab_name=obj.get("prefab_name"),
            extra={k: v for k, v in obj.items() if k not in _NODE_KEYS},
        )

    def to_json(self) -> dict[str, Any]:
        """The node as a JSON object of the VirtualHome schema."""
        out: dict[str, Any] = {
            "id": self.id,
            "category": self.category,
            "class_name": self.class_name,
            "prefab_name": self.prefab_name,
            "obj_transform": self.obj_transform,
            "bounding_box": None if self.bounding_box is None else self.bounding_box.to_json(),
            "properties": list(self.properties),
            "states": list(self.states),
        }
        out.update(self.extra)
        return out


@dataclass(frozen=True, slots=True, order=True)
class Edge:
    """A relation ``from_id RELATION to_id``, e.g. ``(1003, INSIDE, 165)``: plate in the fridge."""

    from_id: int
    relation_type: Relation
    to_id: int

    def __post_init__(self) -> None:
        rel = self.relation_type
        if not isinstance(rel, Relation):
            if not isinstance(rel, str) or rel not in Relation.__members__:
                valid = list(Relation.__members__)
                close = difflib.get_close_matches(str(rel).upper(), valid, n=1)
                hint = f" Did you mean {close[0]!r}?" if close else ""
                raise SceneGraphError(f"edge {self._text()}: unknown relation_type {_short(rel)}."
                                      f"{hint} Valid: {', '.join(valid)}")
            object.__setattr__(self, "relation_type", Relation(rel))
        for name in ("from_id", "to_id"):
            if not _is_int(getattr(self, name)):
                raise SceneGraphError(f"edge {self._text()}: {name} must be an integer node id, "
                                      f"got {_short(getattr(self, name))}")

    def _text(self) -> str:
        rel = self.relation_type
        return f"({_short(self.from_id, 20)} {rel if isinstance(rel, str) else _short(rel, 20)} " \
               f"{_short(self.to_id, 20)})"

    def __str__(self) -> str:
        return self._text()

    @classmethod
    def from_json(cls, obj: object, index: int = 0) -> Edge:
        """Build an edge from its JSON object; ``index`` (its place in "edges") is for messages."""
        if not isinstance(obj, dict):
            raise SceneGraphError(f"edges[{index}] must be an object with from_id, relation_type "
                                  f"and to_id, got {_type_name(obj)}")
        missing = [k for k in _EDGE_KEYS if k not in obj]
        if missing:
            raise SceneGraphError(f"edges[{index}] {_short(obj)} lacks {', '.join(missing)}; an "
                                  'edge reads {"from_id": 1, "relation_type": "ON", "to_id": 2}')
        try:
            return cls(obj["from_id"], obj["relation_type"], obj["to_id"])
        except SceneGraphError as exc:
            raise SceneGraphError(f"edges[{index}]: {exc}") from None

    def to_json(self) -> dict[str, Any]:
        """The edge as a JSON object of the VirtualHome schema."""
        return {"from_id": self.from_id, "relation_type": str(self.relation_type),
                "to_id": self.to_id}


