"""The scene graph: nodes, edges, file I/O and validation of the whole graph."""

from __future__ import annotations

import json
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from siftom.errors import SceneGraphError, UnknownNameError
from siftom.world.scenegraph.elements import (
    DEFAULT_MAX_BYTES,
    MIB,
    Edge,
    Node,
    Relation,
    _type_name,
)

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





def load(path: str | os.PathLike[str], max_bytes: int = DEFAULT_MAX_BYTES) -> SceneGraph:
    """Read and validate a scene-graph JSON file (same as :meth:`SceneGraph.load`)."""
    return SceneGraph.load(path, max_bytes=max_bytes)


def class_counts(nodes: Iterable[Node]) -> dict[str, int]:
    """Count nodes by class name, most common first, ties by name."""
    counts: dict[str, int] = {}
    for n in nodes:
        counts[n.class_name] = counts.get(n.class_name, 0) + 1
    return dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
