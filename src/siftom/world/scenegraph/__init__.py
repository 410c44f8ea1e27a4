"""Scene graphs in the VirtualHome environment-graph JSON schema, and their symbolic view.

A scene graph is ``{"nodes": [...], "edges": [...]}``. A node has an integer ``id``, a
``class_name`` ("fridge"), a ``category`` ("Appliances", "Rooms" ...), ``properties``
("CONTAINERS", "CAN_OPEN", "SURFACES", "GRABBABLE" ...), ``states`` ("OPEN", "CLOSED" ...)
and optionally a ``bounding_box`` (``center``, ``size``), an ``obj_transform`` and a
``prefab_name``. An edge is ``{"from_id", "relation_type", "to_id"}`` and reads
"from ON to", "from INSIDE to" and so on.

:class:`SceneGraph` holds the raw graph and validates it at construction (every error is a
:class:`~siftom.errors.SceneGraphError` naming the node or edge and saying how to fix it).
:meth:`SymbolicScene.of` derives what planning needs: rooms, containers (open or closed),
surfaces, grabbable objects, and for every object its room and its immediate support or
container. The rules are in ``docs/scene-graphs.md``.
"""

from siftom.world.scenegraph.elements import (
    DEFAULT_MAX_BYTES,
    MIB,
    ROOM_CATEGORY,
    BoundingBox,
    Edge,
    Node,
    Relation,
    Vec3,
)
from siftom.world.scenegraph.graph import SceneGraph, class_counts, load
from siftom.world.scenegraph.symbolic import Container, Placement, Room, SymbolicScene

__all__ = [
    "DEFAULT_MAX_BYTES", "MIB", "ROOM_CATEGORY", "BoundingBox", "Container", "Edge", "Node",
    "Placement", "Relation", "Room", "SceneGraph", "SymbolicScene", "Vec3", "class_counts", "load",
]
