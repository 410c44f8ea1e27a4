"""Scene graphs in the VirtualHome environment-graph JSON schema, and their symbolic view.

A scene graph is ``{"nodes": [...], "edges": [...]}``. A node has an integer ``id``, a
``class_name`` ("fridge"), a ``category`` ("Appliances", "Rooms" ...), ``properties``
("CONTAINERS", "CAN_OPEN", "SURFACES", "GRABBABLE" ...), ``states`` ("OPEN", "CLOSED" ...)
and optionally a ``bounding_box`` (``center``, ``size``), an ``obj_transform`` and a
``prefab_name``. An edge is ``{"from_id", "relation_type", "to_id"}`` and reads
"from ON to", "from INSIDE to" and so on.

:class:`SceneGraph` holds the raw graph and validates it at construction (every error is a
:class:`~siftom.errors.SceneGraphError` naming the node or edge and saying how to fix it).
:meth:`SceneGraph.symbolic` derives what planning needs: rooms, containers (open or closed),
surfaces, grabbable objects, and for every object its room and its immediate support or
container. The rules are in ``docs/scene-graphs.md``.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import stat
import tempfile
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

from siftom.errors import SceneGraphError, UnknownNameError, unknown_name

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


# --------------------------------------------------------------------------------------------
# The graph


@dataclass(frozen=True)
class SceneGraph:
    """A validated VirtualHome scene graph: nodes in file order and edges in file order.

    Construction checks that ids are unique, that every edge joins two nodes, and that the
    INSIDE relation has no cycle; anything else raises :class:`SceneGraphError`.
    """

    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]
    _by_id: dict[int, Node] = field(init=False, repr=False, compare=False, hash=False)
    _by_class: dict[str, tuple[Node, ...]] = field(init=False, repr=False, compare=False,
                                                   hash=False)
    _out: dict[int, tuple[Edge, ...]] = field(init=False, repr=False, compare=False, hash=False)
    _in: dict[int, tuple[Edge, ...]] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", tuple(self.nodes))
        object.__setattr__(self, "edges", tuple(self.edges))
        by_id: dict[int, Node] = {}
        for node in self.nodes:
            if not isinstance(node, Node):
                raise SceneGraphError(f"nodes must be Node objects, got {_type_name(node)}")
            if node.id in by_id:
                raise SceneGraphError(
                    f"duplicate node id {node.id}: used by {by_id[node.id].label} and "
                    f"{node.label}; give each node its own id")
            by_id[node.id] = node
        out: dict[int, list[Edge]] = {}
        into: dict[int, list[Edge]] = {}
        for i, edge in enumerate(self.edges):
            if not isinstance(edge, Edge):
                raise SceneGraphError(f"edges must be Edge objects, got {_type_name(edge)}")
            for end in (edge.from_id, edge.to_id):
                if end not in by_id:
                    raise SceneGraphError(
                        f"edges[{i}] {edge} refers to node {end}, which does not exist; add "
                        f"node {end} or remove the edge")
            out.setdefault(edge.from_id, []).append(edge)
            into.setdefault(edge.to_id, []).append(edge)
        by_class: dict[str, list[Node]] = {}
        for node in self.nodes:
            by_class.setdefault(node.class_name, []).append(node)
        object.__setattr__(self, "_by_id", by_id)
        object.__setattr__(self, "_by_class", {k: tuple(v) for k, v in by_class.items()})
        object.__setattr__(self, "_out", {k: tuple(v) for k, v in out.items()})
        object.__setattr__(self, "_in", {k: tuple(v) for k, v in into.items()})
        self._check_inside_acyclic()

    def _check_inside_acyclic(self) -> None:
        # Iterative three-colour DFS: a recursive one would overflow on long INSIDE chains.
        inside: dict[int, list[int]] = {}
        for e in self.edges:
            if e.relation_type is Relation.INSIDE:
                inside.setdefault(e.from_id, []).append(e.to_id)
        state: dict[int, int] = {}  # 1 = on the current path, 2 = finished
        for start in inside:
            if start in state:
                continue
            path = [start]
            iters = [iter(inside.get(start, ()))]
            state[start] = 1
            while iters:
                nxt = next(iters[-1], None)
                if nxt is None:
                    state[path.pop()] = 2
                    iters.pop()
                elif state.get(nxt) == 1:
                    cycle = [*path[path.index(nxt):], nxt]
                    text = " INSIDE ".join(self._by_id[i].label for i in cycle)
                    raise SceneGraphError(
                        f"INSIDE cycle between nodes {', '.join(map(str, cycle[:-1]))}: {text}; "
                        "an object cannot be inside itself, remove one of these INSIDE edges")
                elif nxt not in state:
                    state[nxt] = 1
                    path.append(nxt)
                    iters.append(iter(inside.get(nxt, ())))

    # ---------------------------------------------------------------- reading and writing

    @classmethod
    def from_json(cls, obj: object) -> SceneGraph:
        """Build and validate a graph from the parsed JSON (``{"nodes": [...], "edges": [...]}``)."""
        if not isinstance(obj, dict):
            raise SceneGraphError(f"a scene graph must be a JSON object with 'nodes' and 'edges' "
                                  f"lists, got {_type_name(obj)}")
        for key in ("nodes", "edges"):
            if key not in obj:
                wrapped = ""
                if len(obj) == 1 and isinstance(next(iter(obj.values())), dict):
                    wrapped = (f"; the graph seems wrapped in {next(iter(obj))!r}: use that "
                               "object as the top level")
                raise SceneGraphError(f"a scene graph needs a {key!r} list at the top level; found "
                                      f"keys {sorted(map(str, obj))[:10]}{wrapped}")
            if not isinstance(obj[key], list):
                raise SceneGraphError(f"{key!r} must be a list, got {_type_name(obj[key])}")
        nodes = tuple(Node.from_json(n, i) for i, n in enumerate(obj["nodes"]))
        edges = tuple(Edge.from_json(e, i) for i, e in enumerate(obj["edges"]))
        return cls(nodes, edges)

    @classmethod
    def parse(cls, text: str | bytes, source: str = "<string>") -> SceneGraph:
        """Parse JSON text into a validated graph; ``source`` names it in error messages."""
        if isinstance(text, bytes):
            try:
                text = text.decode("utf-8-sig")
            except UnicodeDecodeError as exc:
                raise SceneGraphError(f"{source} is not UTF-8 text (bad byte at offset "
                                      f"{exc.start}); save it as UTF-8 JSON") from None
        try:
            obj = json.loads(text)
        except json.JSONDecodeError as exc:
            raise SceneGraphError(f"{source} is not valid JSON: {exc.msg} at line {exc.lineno}, "
                                  f"column {exc.colno}") from None
        except RecursionError:
            raise SceneGraphError(f"{source} nests JSON too deeply to be a scene graph") from None
        except ValueError as exc:  # e.g. an integer with more digits than Python allows
            raise SceneGraphError(f"{source} is not a usable JSON document: {exc}") from None
        try:
            return cls.from_json(obj)
        except SceneGraphError as exc:
            raise SceneGraphError(f"{source}: {exc}") from None

    @classmethod
    def load(cls, path: str | os.PathLike[str], max_bytes: int = DEFAULT_MAX_BYTES) -> SceneGraph:
        """Read and validate a scene-graph JSON file.

        The size is checked with ``os.stat`` before reading, so a huge file is refused at once;
        at most ``max_bytes + 1`` bytes are ever read, even from a file that grows meanwhile.
        """
        p = Path(path)
        try:
            st = p.stat()
        except FileNotFoundError:
            raise SceneGraphError(f"{p}: no such file; check the path") from None
        except OSError as exc:
            raise SceneGraphError(f"{p}: cannot read ({exc.strerror})") from None
        if stat.S_ISDIR(st.st_mode):
            raise SceneGraphError(f"{p} is a directory; give the path of a scene-graph .json file")
        if not stat.S_ISREG(st.st_mode):
            raise SceneGraphError(f"{p} is not a regular file; give a scene-graph .json file")
        too_big = (f"larger than the {max_bytes / MIB:.1f} MB limit for scene graphs; if it really "
                   "is one, raise the limit (SceneGraph.load(path, max_bytes=...))")
        if st.st_size > max_bytes:
            raise SceneGraphError(f"{p} is {st.st_size / MIB:.1f} MB, {too_big}")
        try:
            with p.open("rb") as fh:
                data = fh.read(max_bytes + 1)
        except OSError as exc:
            raise SceneGraphError(f"{p}: cannot read ({exc.strerror})") from None
        if len(data) > max_bytes:
            raise SceneGraphError(f"{p} is {too_big}")
        return cls.parse(data, source=str(p))

    def to_json(self) -> dict[str, Any]:
        """The graph as a JSON object of the VirtualHome schema (nodes and edges in order)."""
        return {"nodes": [n.to_json() for n in self.nodes],
                "edges": [e.to_json() for e in self.edges]}

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the graph as JSON atomically: a temporary file in the same folder, then rename."""
        p = Path(path)
        text = json.dumps(self.to_json(), indent=1)
        tmp_name = None
        try:
            fd, tmp_name = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp",
                                            dir=p.parent if str(p.parent) else ".")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp_name, p)
            tmp_name = None
        except OSError as exc:
            raise SceneGraphError(f"cannot write scene graph to {p}: {exc.strerror or exc}; check "
                                  "that the folder exists and is writable") from None
        finally:
            if tmp_name is not None:
                Path(tmp_name).unlink(missing_ok=True)

    # ---------------------------------------------------------------- lookups

    def __len__(self) -> int:
        return len(self.nodes)

    def __contains__(self, node_id: object) -> bool:
        return node_id in self._by_id

    def __iter__(self) -> Iterator[Node]:
        return iter(self.nodes)

    def node(self, node_id: int) -> Node:
        """The node with this id; raise UnknownNameError if there is none."""
        try:
            return self._by_id[node_id]
        except (KeyError, TypeError):
            raise UnknownNameError(f"no node with id {node_id!r} in this scene graph "
                                   f"({len(self.nodes)} nodes)") from None

    def nodes_of_class(self, class_name: str) -> tuple[Node, ...]:
        """All nodes of a class, in file order (empty if none)."""
        return self._by_class.get(class_name, ())

    @property
    def class_names(self) -> tuple[str, ...]:
        """Every class name in the graph, sorted."""
        return tuple(sorted(self._by_class))

    def edges_from(self, node_id: int, relation: Relation | str | None = None) -> tuple[Edge, ...]:
        """Edges leaving a node, optionally only one relation type."""
        edges = self._out.get(node_id, ())
        return edges if relation is None else tuple(e for e in edges if e.relation_type == relation)

    def edges_to(self, node_id: int, relation: Relation | str | None = None) -> tuple[Edge, ...]:
        """Edges entering a node, optionally only one relation type."""
        edges = self._in.get(node_id, ())
        return edges if relation is None else tuple(e for e in edges if e.relation_type == relation)

    def rooms(self) -> tuple[Node, ...]:
        """The room nodes (category ``Rooms``), in file order."""
        return tuple(n for n in self.nodes if n.is_room)

    def symbolic(self) -> SymbolicScene:
        """Derive the symbolic view; see :class:`SymbolicScene` and docs/scene-graphs.md."""
        return _derive(self)


# --------------------------------------------------------------------------------------------
# The symbolic view


@dataclass(frozen=True, slots=True)
class Room:
    """A room: its node id, name (class_name) and position (centre), if known."""

    id: int
    name: str
    position: Vec3 | None = None


@dataclass(frozen=True, slots=True)
class Container:
    """Something objects can be INSIDE. ``is_open`` is False only for a closed openable one."""

    id: int
    class_name: str
    openable: bool
    is_open: bool


@dataclass(frozen=True, slots=True)
class Placement:
    """Where a non-room node is.

    ``room`` is the room it is in (directly or through what holds it), ``parent`` the
    innermost non-room node it is INSIDE or ON, and ``relation`` which of the two
    (None with ``parent``).
    """

    id: int
    class_name: str
    room: int | None
    parent: int | None
    relation: Relation | None
    position: Vec3 | None = None


@dataclass(frozen=True)
class SymbolicScene:
    """What planning needs from a scene graph (rules in docs/scene-graphs.md).

    Every tuple is sorted by node id. ``placements`` has one entry per non-room node.
    """

    rooms: tuple[Room, ...]
    containers: tuple[Container, ...]
    surfaces: tuple[int, ...]
    grabbables: tuple[int, ...]
    placements: tuple[Placement, ...]
    _room: dict[int, Room] = field(init=False, repr=False, compare=False, hash=False)
    _container: dict[int, Container] = field(init=False, repr=False, compare=False, hash=False)
    _placement: dict[int, Placement] = field(init=False, repr=False, compare=False, hash=False)
    _surface: frozenset[int] = field(init=False, repr=False, compare=False, hash=False)
    _grabbable: frozenset[int] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_surface", frozenset(self.surfaces))
        object.__setattr__(self, "_grabbable", frozenset(self.grabbables))
        object.__setattr__(self, "_room", {r.id: r for r in self.rooms})
        object.__setattr__(self, "_container", {c.id: c for c in self.containers})
        object.__setattr__(self, "_placement", {p.id: p for p in self.placements})

    def room_named(self, name: str) -> Room:
        """The first room (lowest id) whose name is ``name``; UnknownNameError lists the rooms."""
        for room in self.rooms:
            if room.name == name:
                return room
        raise unknown_name("room", name, {r.name for r in self.rooms})

    def container(self, node_id: int) -> Container | None:
        """The container with this id, or None if the node is not a container."""
        return self._container.get(node_id)

    def is_surface(self, node_id: int) -> bool:
        """Whether the node has the SURFACES property."""
        return node_id in self._surface

    def is_grabbable(self, node_id: int) -> bool:
        """Whether the node has the GRABBABLE property."""
        return node_id in self._grabbable

    def placement(self, node_id: int) -> Placement:
        """Where a non-room node is; UnknownNameError for rooms and unknown ids."""
        try:
            return self._placement[node_id]
        except KeyError:
            raise UnknownNameError(f"no placement for node {node_id!r}: it is a room or not in "
                                   "the graph") from None

    def room_of(self, node_id: int) -> int | None:
        """The id of the room the node is in (a room is in itself), or None if unknown."""
        if node_id in self._room:
            return node_id
        return self.placement(node_id).room

    def position(self, node_id: int) -> Vec3 | None:
        """The node's position (bounding-box centre), or None if the graph gives none."""
        if node_id in self._room:
            return self._room[node_id].position
        return self.placement(node_id).position

    def enclosing_containers(self, node_id: int) -> tuple[int, ...]:
        """Containers around the node, innermost first, following parents up to the room.

        The node can be reached only if each of them is open. A container is listed when a
        node on the chain is INSIDE it.
        """
        out: list[int] = []
        seen = {node_id}
        current = self._placement.get(node_id)
        while current is not None and current.parent is not None:
            if current.relation is Relation.INSIDE and current.parent in self._container:
                out.append(current.parent)
            if current.parent in seen:
                break
            seen.add(current.parent)
            current = self._placement.get(current.parent)
        return tuple(out)

    def is_reachable(self, node_id: int) -> bool:
        """Whether every container around the node is open."""
        return all(self._container[c].is_open for c in self.enclosing_containers(node_id))

    def contents(self, node_id: int) -> tuple[int, ...]:
        """Ids of the nodes whose parent is this node (INSIDE or ON it), sorted."""
        return tuple(p.id for p in self.placements if p.parent == node_id)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict of the whole view."""
        return {
            "rooms": [{"id": r.id, "name": r.name, "position": r.position} for r in self.rooms],
            "containers": [{"id": c.id, "class_name": c.class_name, "openable": c.openable,
                            "open": c.is_open} for c in self.containers],
            "surfaces": list(self.surfaces),
            "grabbables": list(self.grabbables),
            "placements": [{"id": p.id, "class_name": p.class_name, "room": p.room,
                            "parent": p.parent,
                            "relation": None if p.relation is None else str(p.relation),
                            "position": p.position} for p in self.placements],
        }


def _is_container(graph: SceneGraph, node: Node) -> bool:
    # CAN_OPEN alone does not make a container: doors, windows, curtains, books and milk
    # cartons can be opened but hold nothing. Anything something is INSIDE is one, though.
    if node.is_room:
        return False
    if node.has_property("CONTAINERS"):
        return True
    return any(not graph.node(e.from_id).is_room
               for e in graph.edges_to(node.id, Relation.INSIDE))


def _container(node: Node) -> Container:
    openable = node.has_property("CAN_OPEN") or "OPEN" in node.states or "CLOSED" in node.states
    # An openable container is closed unless it says OPEN (VirtualHome's default for
    # openable objects); one that cannot be opened (sink, shelf, toaster) is always open.
    return Container(node.id, node.class_name, openable, "OPEN" in node.states or not openable)


def _derive(graph: SceneGraph) -> SymbolicScene:
    by_id = graph._by_id
    ordered = sorted(graph.nodes, key=lambda n: n.id)

    def volume(node_id: int) -> float:
        box = by_id[node_id].bounding_box
        return box.volume if box is not None else math.inf

    def top(node_id: int) -> float:
        box = by_id[node_id].bounding_box
        return box.center[1] + box.size[1] / 2 if box is not None else -math.inf

    def smaller(a: int, b: int) -> bool:  # a's box is smaller than b's (both known)
        box_a, box_b = by_id[a].bounding_box, by_id[b].bounding_box
        return box_a is not None and box_b is not None and box_a.volume < box_b.volume

    # Candidate holders: INSIDE/ON edges to non-room nodes other than the node itself.
    holders: dict[int, list[tuple[Relation, int]]] = {}
    direct_rooms: dict[int, list[int]] = {}
    for e in graph.edges:
        if e.relation_type not in _PLACEMENT or e.from_id == e.to_id:
            continue
        if by_id[e.to_id].is_room:
            if e.relation_type is Relation.INSIDE:
                direct_rooms.setdefault(e.from_id, []).append(e.to_id)
        elif not (e.relation_type is Relation.INSIDE and smaller(e.to_id, e.from_id)):
            # Nothing fits inside a smaller box: such an INSIDE edge is an artefact of
            # VirtualHome's box tests (apartment_graph_2: a kitchen counter INSIDE the
            # dishwasher built into it), and would wrongly shut everything on the counter away.
            holders.setdefault(e.from_id, []).append((e.relation_type, e.to_id))

    def innermost(targets: list[int]) -> list[int]:
        # Drop every target that holds another target, directly or through other holders.
        # ON cycles are tolerated (VirtualHome computes ON from bounding boxes and can make it
        # mutual): if every target would go, keep them all. The search looks at no more than
        # _HOLDS_SEARCH_LIMIT edges, so a pathological graph (thousands of nodes stacked on
        # one another) stays linear instead of quadratic; real chains are a few edges long.
        held_by_targets: set[int] = set()
        expanded: set[int] = set()
        queue = deque(targets)
        budget = _HOLDS_SEARCH_LIMIT
        while queue and budget > 0:
            cur = queue.popleft()
            if cur in expanded:
                continue
            expanded.add(cur)
            above = holders.get(cur, ())
            budget -= len(above) + 1
            for _, t in above:
                if t not in held_by_targets:
                    held_by_targets.add(t)
                    queue.append(t)
        return [t for t in targets if t not in held_by_targets] or targets

    def choose_parent(node_id: int) -> tuple[Relation, int] | None:
        cands = holders.get(node_id, ())
        for rel in _PLACEMENT:  # INSIDE first: the container decides whether it can be reached
            targets = sorted({t for r, t in cands if r is rel})
            if len(targets) > 1:
                targets = innermost(targets)
            if targets and rel is Relation.INSIDE:  # the smallest container is the innermost
                return rel, min(targets, key=lambda t: (volume(t), t))
            if targets:  # the highest top is the support right under the object
                return rel, min(targets, key=lambda t: (-top(t), t))
        return None

    def pick_room(node: Node, candidates: list[int]) -> int:
        # Several rooms (a door between two): the one whose box holds the node, else lowest id.
        pos = node.position
        if len(candidates) > 1 and pos is not None:
            around = [r for r in candidates
                      if (box := by_id[r].bounding_box) is not None and box.contains(pos)]
            if around:
                return min(around)
        return min(candidates)

    parents = {n.id: choose_parent(n.id) for n in ordered if not n.is_room}
    room: dict[int, int | None] = {}
    for node in ordered:
        # Follow the parent chain up to a node INSIDE a room; memoise along the way.
        path: list[int] = []
        on_path: set[int] = set()
        cur: int | None = node.id
        found: int | None = None
        while cur is not None and cur not in on_path:
            if cur in room:
                found = room[cur]
                break
            if cur in direct_rooms:
                found = pick_room(by_id[cur], direct_rooms[cur])
                break
            path.append(cur)
            on_path.add(cur)
            parent = parents.get(cur)
            cur = None if parent is None else parent[1]
        for p in path:
            room[p] = found
        if cur is not None and cur not in room:
            room[cur] = found
    for node in ordered:
        # A parent chain that never reaches a room: borrow the room of any other holder.
        if room.get(node.id) is None and not node.is_room:
            room[node.id] = next((room[t] for _, t in holders.get(node.id, ())
                                  if room.get(t) is not None), None)

    placements = []
    for node in ordered:
        if node.is_room:
            continue
        parent = parents[node.id]
        placements.append(Placement(
            node.id, node.class_name, room[node.id],
            None if parent is None else parent[1], None if parent is None else parent[0],
            node.position))
    return SymbolicScene(
        rooms=tuple(Room(n.id, n.class_name, n.position) for n in ordered if n.is_room),
        containers=tuple(_container(n) for n in ordered if _is_container(graph, n)),
        surfaces=tuple(n.id for n in ordered if not n.is_room and n.has_property("SURFACES")),
        grabbables=tuple(n.id for n in ordered if not n.is_room and n.has_property("GRABBABLE")),
        placements=tuple(placements),
    )


def load(path: str | os.PathLike[str], max_bytes: int = DEFAULT_MAX_BYTES) -> SceneGraph:
    """Read and validate a scene-graph JSON file (same as :meth:`SceneGraph.load`)."""
    return SceneGraph.load(path, max_bytes=max_bytes)


def class_counts(nodes: Iterable[Node]) -> dict[str, int]:
    """Count nodes by class name, most common first, ties by name."""
    counts: dict[str, int] = {}
    for n in nodes:
        counts[n.class_name] = counts.get(n.class_name, 0) + 1
    return dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
