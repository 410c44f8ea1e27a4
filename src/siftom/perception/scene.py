"""From a validated VirtualHome scene graph to siftom's world JSON (what ``siftom infer --scene`` reads).

The graph is checked by :class:`~siftom.world.scenegraph.SceneGraph` (ids, edges, relations,
INSIDE cycles) and its symbolic view decides rooms, containers, surfaces and parents
(docs/scene-graphs.md). On top of that a perceived scene must say where the person stands
and where every object is; anything missing is an error whose message is sent back to the
model once (never guessed).

Naming: a node is called by its class name when it is the only one of its class, else
``class_1``, ``class_2`` ... in id order (``bowl_1``); class names are lower case with ``_``
for spaces. Objects keep VirtualHome's class names except the ones siftom maps
(``cutleryfork`` -> ``fork``, ``siftom.world.io.VH_ALIASES``).
"""

from __future__ import annotations

import re
from collections import Counter, defaultdict
from dataclasses import dataclass
from typing import Any

from siftom.errors import PerceptionError, SceneGraphError
from siftom.world.io import VH_ALIASES
from siftom.world.scenegraph import Relation, SceneGraph, SymbolicScene

HUMAN_CLASSES = ("character", "human", "person")
ROBOT_CLASSES = ("robot",)
MAX_PLACES = 62  # World's open_mask is a 64-bit integer


def clean_class(name: str) -> str:
    """``Kitchen Counter`` -> ``kitchen_counter``; VirtualHome aliases -> siftom classes."""
    cls = re.sub(r"[^0-9a-z]+", "_", name.strip().lower()).strip("_") or "thing"
    return VH_ALIASES.get(cls, cls)


@dataclass(frozen=True, eq=False)
class PerceivedScene:
    """A scene graph and the world JSON derived from it (without target and goals yet).

    Attributes:
        graph: the validated graph.
        world: ``places``, ``items``, ``agents``, ``open`` of siftom's world JSON.
        names: node id -> the name used in ``world`` and in action strings.
    """

    graph: SceneGraph
    world: dict[str, Any]
    names: dict[int, str]


def parse_scene(answer: Any) -> PerceivedScene:
    """Validate a schema-valid answer as a scene graph and derive the world; PerceptionError otherwise."""
    try:
        graph = SceneGraph.from_json(answer)
    except SceneGraphError as exc:
        raise PerceptionError(f"invalid scene graph: {exc}") from None
    return scene_to_world(graph)


def scene_to_world(graph: SceneGraph, strict: bool = True) -> PerceivedScene:
    """Rooms -> room names, surfaces/containers -> places, grabbable objects -> items, agents.

    ``strict`` (a perceived scene): an object on no furniture is an error sent back to the
    model. Otherwise (a given VirtualHome graph, where chairs and towel racks stand in rooms)
    such objects are left out, as ``siftom infer --scene`` does.
    """
    view = SymbolicScene.of(graph)
    if not view.rooms:
        raise PerceptionError("the scene graph has no room; add a node with category \"Rooms\" (e.g. "
                              "class_name \"kitchen\") and an INSIDE edge from each piece of furniture to it")
    agent_ids = {n.id for n in graph.nodes if clean_class(n.class_name) in HUMAN_CLASSES + ROBOT_CLASSES}
    items: list[int] = []
    item_parent: dict[int, int] = {}
    problems: list[str] = []
    for nid in view.grabbables:
        if nid in agent_ids:
            continue
        parent = view.placement(nid).parent
        seen = {nid}
        while parent is not None and view.is_grabbable(parent) and parent not in seen:  # a stack of bowls
            seen.add(parent)
            parent = view.placement(parent).parent
        if parent is None or view.is_grabbable(parent):
            held = any(e.relation_type in (Relation.HOLDS_RH, Relation.HOLDS_LH) for e in graph.edges_to(nid))
            why = ("is held in the first frame; siftom's world starts with empty hands, so start from a frame "
                   "where it lies somewhere" if held else
                   "is not ON or INSIDE any furniture; add the edge to the surface or container it is on or in")
            if strict:
                problems.append(f"object {graph.node(nid).label} {why}")
            continue
        items.append(nid)
        item_parent[nid] = parent
    place_ids = sorted(({*view.surfaces} | {c.id for c in view.containers} | set(item_parent.values()))
                       - agent_ids - set(items))
    if len(place_ids) > MAX_PLACES:  # a whole apartment: keep the furniture that matters to fetching
        used = set(item_parent.values())
        for classes in (HUMAN_CLASSES, ROBOT_CLASSES):
            at = _agent_place(graph, classes, set(place_ids))
            if at is not None:
                used.add(at)
        place_ids = sorted(used)
    if len(place_ids) > MAX_PLACES:
        raise PerceptionError(f"the scene has {len(place_ids)} surfaces and containers; at most {MAX_PLACES} "
                              "are supported, list only the furniture that holds objects or where people stand")
    room_name = _names(graph, [r.id for r in view.rooms])
    for pid in place_ids:
        if view.room_of(pid) is None:
            problems.append(f"furniture {graph.node(pid).label} is in no room; add an INSIDE edge to its room")
    if problems:
        more = f"; and {len(problems) - 5} more" if len(problems) > 5 else ""
        raise PerceptionError("invalid scene: " + "; ".join(problems[:5]) + more)
    names = _names(graph, sorted(place_ids + items))
    places = []
    for pid in place_ids:
        cont = view.container(pid)
        closable = bool(cont is not None and cont.openable)
        pos = view.position(pid) or (0.0, 0.0, 0.0)
        room = view.room_of(pid)
        assert room is not None  # a place in no room was rejected above
        places.append({"name": names[pid], "kind": "container" if closable else "surface",
                       "room": room_name[room], "pos": [round(pos[0], 3), round(pos[2], 3)],
                       "closable": closable})
    human = _agent_place(graph, HUMAN_CLASSES, set(place_ids))
    if human is None and strict:
        raise PerceptionError("invalid scene: no person; add a node with class_name \"character\" and a CLOSE "
                              "edge from it to the furniture the person stands at")
    if human is None:  # a given graph without a character (apartment_graph.json): the first place
        human = place_ids[0]
    robot = _agent_place(graph, ROBOT_CLASSES, set(place_ids))
    agents = {"human": names[human], "robot": names[robot if robot is not None else human]}
    world = {
        "places": places,
        "items": [{"name": names[i], "class": clean_class(graph.node(i).class_name), "at": names[item_parent[i]]}
                  for i in items],
        "agents": agents,
        "open": [names[c.id] for c in view.containers if c.id in names and c.openable and c.is_open],
    }
    return PerceivedScene(graph, world, names)


def _names(graph: SceneGraph, ids: list[int]) -> dict[int, str]:
    """``class`` when a class occurs once among ``ids``, else ``class_1``, ``class_2`` … in order."""
    counts = Counter(clean_class(graph.node(i).class_name) for i in ids)
    seen: dict[str, int] = defaultdict(int)
    out = {}
    for i in ids:
        cls = clean_class(graph.node(i).class_name)
        seen[cls] += 1
        out[i] = cls if counts[cls] == 1 else f"{cls}_{seen[cls]}"
    return out


def _agent_place(graph: SceneGraph, classes: tuple[str, ...], places: set[int]) -> int | None:
    """The furniture the agent is CLOSE to (or ON/INSIDE), lowest id first; else the nearest one."""
    for node in graph.nodes:
        if clean_class(node.class_name) in classes:
            near = sorted(e.to_id for e in graph.edges_from(node.id)
                          if e.relation_type in (Relation.CLOSE, Relation.ON, Relation.INSIDE) and e.to_id in places)
            if near:
                return near[0]
            here = node.position
            if here is None:
                continue
            placed = [(p, graph.node(p).position) for p in sorted(places)]
            dist = [((x[0] - here[0]) ** 2 + (x[2] - here[2]) ** 2, p) for p, x in placed if x is not None]
            if dist:
                return min(dist)[1]
    return None


def graph_from_world(world: Any, state: Any, target: int | None = None) -> SceneGraph:
    """The VirtualHome graph a perfect model would report for a siftom world and state.

    Used to describe a known world to the model and by the tests as the ideal answer. Room
    ids start at 1, furniture at 100, objects at 1000, the person is 9000 and the robot 9001.
    """
    from siftom.world.model import HELD

    rooms = sorted({p.room for p in world.places})
    rid = {r: 1 + k for k, r in enumerate(rooms)}
    nodes: list[dict[str, Any]] = []
    edges: list[dict[str, Any]] = []
    box = {"center": [0.0, 0.0, 0.0], "size": [4.0, 3.0, 4.0]}
    for r in rooms:
        nodes.append({"id": rid[r], "class_name": r, "category": "Rooms", "properties": [], "states": [],
                      "bounding_box": box})
    for k, p in enumerate(world.places):
        props = ["SURFACES"] if p.kind != "container" else ["CONTAINERS"] + (["CAN_OPEN"] if p.closable else [])
        states = (["OPEN"] if state.is_open(k) else ["CLOSED"]) if p.closable else []
        nodes.append({"id": 100 + k, "class_name": p.name, "category": "Furniture", "properties": props,
                      "states": states, "bounding_box": {"center": [p.pos[0], 0.5, p.pos[1]], "size": [1.0, 1.0, 1.0]}})
        edges.append({"from_id": 100 + k, "relation_type": "INSIDE", "to_id": rid[p.room]})
    for k, it in enumerate(world.items):
        at = state.item_at[k]
        p = world.places[at] if at != HELD else None
        nodes.append({"id": 1000 + k, "class_name": it.cls, "category": "Props", "properties": ["GRABBABLE"],
                      "states": [], "bounding_box": {"center": [p.pos[0] if p else 0.0, 1.0, p.pos[1] if p else 0.0],
                                                     "size": [0.1, 0.1, 0.1]}})
        if p is not None:
            rel = "INSIDE" if p.kind == "container" else "ON"
            edges.append({"from_id": 1000 + k, "relation_type": rel, "to_id": 100 + at})
    for aid, cls, agent in ((9000, "character", 0), (9001, "robot", 1)):
        nodes.append({"id": aid, "class_name": cls, "category": "Characters", "properties": [], "states": [],
                      "bounding_box": {"center": [0.0, 1.0, 0.0], "size": [0.5, 1.8, 0.5]}})
        edges.append({"from_id": aid, "relation_type": "CLOSE", "to_id": 100 + state.agent_at[agent]})
        if state.held[agent] >= 0:
            edges.append({"from_id": aid, "relation_type": "HOLDS_RH", "to_id": 1000 + state.held[agent]})
    return SceneGraph.from_json({"nodes": nodes, "edges": edges})
