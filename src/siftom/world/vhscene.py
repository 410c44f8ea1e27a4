"""VirtualHome scene graphs -> World + State: furniture holding known objects become places."""

from __future__ import annotations

from collections import Counter
from typing import Any

from siftom.errors import ObservationError, SceneGraphError
from siftom.world.library import GoalSpec, LoadedScene, feasible_goals, goal_library
from siftom.world.model import NOTHING, Item, Place, State, World

# VirtualHome class names -> siftom object classes
VH_ALIASES = {
    "cutleryfork": "fork", "cutleryknife": "knife", "spoon": "spoon", "dishbowl": "bowl", "plate": "plate",
    "wineglass": "wineglass", "waterglass": "waterglass", "mug": "mug", "coffeecup": "cup", "cup": "cup",
    "milk": "milk", "cereal": "cereal", "bananas": "banana", "breadslice": "bread", "chicken": "chicken",
    "juice": "orange_juice", "chocolatesyrup": "syrup", "condimentshaker": "salt", "salmon": "salmon",
}


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
    want = target or ("kitchentable" if goal_space == "household-table-v0" else "kitchencounter")
    tnode = _target_node(graph, view, want)
    spec = GoalSpec(goal_space, goals)
    known = {c for g in goal_library(spec, 0) for c, _n in g.counts}
    lib = "given" if goals is not None else goal_space
    objs, unknown, loose, why = _grabbables(graph, view, known, lib)
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
    places, pidx = _places(graph, view, parents)
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


def _target_node(graph: Any, view: Any, want: str) -> int:
    """The first surface whose class name or label is ``want``."""
    for nid in view.surfaces:
        node = graph.node(nid)
        if node.class_name == want or node.label == want:
            found: int = nid
            return found
    raise SceneGraphError(f"no surface named {want!r} to use as the target; pass target=CLASS_NAME")


def _grabbables(graph: Any, view: Any, known: set[str],
                lib: str) -> tuple[list[Any], Counter[str], Counter[str], dict[int, str]]:
    """The objects a goal uses with the furniture under them ``(node id, class, furniture id)``;
    the classes left out (no goal uses them; they rest on no furniture) and why, per node id."""
    objs: list[Any] = []
    unknown: Counter[str] = Counter()
    loose: Counter[str] = Counter()
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
    return objs, unknown, loose, why


def _places(graph: Any, view: Any, parents: list[int]) -> tuple[list[Place], dict[Any, int]]:
    """A place per kept piece of furniture (its floor position, room, and whether it opens)."""
    places: list[Place] = []
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
    return places, pidx


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
