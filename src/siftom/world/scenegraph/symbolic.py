"""The symbolic view of a scene graph: rooms, containers, surfaces and where each object is."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from siftom.errors import UnknownNameError, unknown_name
from siftom.world.scenegraph.elements import (
    _HOLDS_SEARCH_LIMIT,
    _PLACEMENT,
    Node,
    Relation,
    Vec3,
)
from siftom.world.scenegraph.graph import SceneGraph

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

    @classmethod
    def of(cls, graph: SceneGraph) -> SymbolicScene:
        """Derive the symbolic view of ``graph`` (the rules in docs/scene-graphs.md)."""
        return derive(graph)


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


_Holders = dict[int, list[tuple[Relation, int]]]


def _smaller(by_id: dict[int, Node], a: int, b: int) -> bool:
    """Whether a's box is smaller than b's (both known)."""
    box_a, box_b = by_id[a].bounding_box, by_id[b].bounding_box
    return box_a is not None and box_b is not None and box_a.volume < box_b.volume


def _holders(graph: SceneGraph) -> tuple[_Holders, dict[int, list[int]]]:
    """Candidate holders: INSIDE/ON edges to non-room nodes other than the node itself; and the
    rooms each node is directly INSIDE."""
    by_id = graph._by_id
    holders: _Holders = {}
    direct_rooms: dict[int, list[int]] = {}
    for e in graph.edges:
        if e.relation_type not in _PLACEMENT or e.from_id == e.to_id:
            continue
        if by_id[e.to_id].is_room:
            if e.relation_type is Relation.INSIDE:
                direct_rooms.setdefault(e.from_id, []).append(e.to_id)
        elif not (e.relation_type is Relation.INSIDE and _smaller(by_id, e.to_id, e.from_id)):
            # Nothing fits inside a smaller box: such an INSIDE edge is an artefact of
            # VirtualHome's box tests (apartment_graph_2: a kitchen counter INSIDE the
            # dishwasher built into it), and would wrongly shut everything on the counter away.
            holders.setdefault(e.from_id, []).append((e.relation_type, e.to_id))
    return holders, direct_rooms


def _innermost(holders: _Holders, targets: list[int]) -> list[int]:
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


def _choose_parent(by_id: dict[int, Node], holders: _Holders, node_id: int) -> tuple[Relation, int] | None:
    def volume(node_id: int) -> float:
        box = by_id[node_id].bounding_box
        return box.volume if box is not None else math.inf

    def top(node_id: int) -> float:
        box = by_id[node_id].bounding_box
        return box.center[1] + box.size[1] / 2 if box is not None else -math.inf

    cands = holders.get(node_id, ())
    for rel in _PLACEMENT:  # INSIDE first: the container decides whether it can be reached
        targets = sorted({t for r, t in cands if r is rel})
        if len(targets) > 1:
            targets = _innermost(holders, targets)
        if targets and rel is Relation.INSIDE:  # the smallest container is the innermost
            return rel, min(targets, key=lambda t: (volume(t), t))
        if targets:  # the highest top is the support right under the object
            return rel, min(targets, key=lambda t: (-top(t), t))
    return None


def _pick_room(by_id: dict[int, Node], node: Node, candidates: list[int]) -> int:
    # Several rooms (a door between two): the one whose box holds the node, else lowest id.
    pos = node.position
    if len(candidates) > 1 and pos is not None:
        around = [r for r in candidates
                  if (box := by_id[r].bounding_box) is not None and box.contains(pos)]
        if around:
            return min(around)
    return min(candidates)


def _rooms(by_id: dict[int, Node], ordered: list[Node], holders: _Holders, direct_rooms: dict[int, list[int]],
           parents: dict[int, tuple[Relation, int] | None]) -> dict[int, int | None]:
    """The room of every node: up its parent chain to a node INSIDE a room."""
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
                found = _pick_room(by_id, by_id[cur], direct_rooms[cur])
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
    return room


def derive(graph: SceneGraph) -> SymbolicScene:
    by_id = graph._by_id
    ordered = sorted(graph.nodes, key=lambda n: n.id)
    holders, direct_rooms = _holders(graph)
    parents = {n.id: _choose_parent(by_id, holders, n.id) for n in ordered if not n.is_room}
    room = _rooms(by_id, ordered, holders, direct_rooms, parents)
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
