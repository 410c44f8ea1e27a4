"""Scene graphs: loading, validation, the symbolic view and ``siftom scene inspect``."""

from __future__ import annotations

import contextlib
import copy
import json
import os
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from siftom.cli import main, root
from siftom.errors import SceneGraphError, SiftomError, UnknownNameError
from siftom.world.scenegraph import (
    MIB,
    BoundingBox,
    Edge,
    Node,
    Relation,
    SceneGraph,
    SymbolicScene,
)

FIXTURES = Path(__file__).parents[1] / "fixtures"
HOUSE = FIXTURES / "scene_three_rooms.json"
VIRTUALHOME = Path(__file__).parents[2] / "data" / "virtualhome"

needs_virtualhome = pytest.mark.skipif(
    not (VIRTUALHOME / "apartment_graph.json").exists(),
    reason=f"real VirtualHome graphs not found at {VIRTUALHOME}",
)


def house_json() -> dict[str, Any]:
    return json.loads(HOUSE.read_text())


@pytest.fixture(scope="module")
def house() -> SceneGraph:
    return SceneGraph.load(HOUSE)


@pytest.fixture(scope="module")
def apartment() -> SceneGraph:
    if not (VIRTUALHOME / "apartment_graph.json").exists():
        pytest.skip(f"real VirtualHome graphs not found at {VIRTUALHOME}")
    return SceneGraph.load(VIRTUALHOME / "apartment_graph.json")


@pytest.fixture(scope="module")
def apartment2() -> SceneGraph:
    if not (VIRTUALHOME / "apartment_graph_2.json").exists():
        pytest.skip(f"real VirtualHome graphs not found at {VIRTUALHOME}")
    return SceneGraph.load(VIRTUALHOME / "apartment_graph_2.json")


# ---------------------------------------------------------------- the hand-built house


def test_house_lookups(house: SceneGraph) -> None:
    assert len(house) == 22 and len(house.edges) == 36
    assert house.node(10).class_name == "fridge"
    assert [n.id for n in house.nodes_of_class("fridge")] == [10]
    assert house.nodes_of_class("unicorn") == ()
    assert 10 in house and 999 not in house
    assert {e.to_id for e in house.edges_from(42, Relation.INSIDE)} == {3, 40, 41}
    assert {e.from_id for e in house.edges_to(12, "ON")} == {22, 23}
    with pytest.raises(UnknownNameError, match="999"):
        house.node(999)


def test_house_symbolic_view(house: SceneGraph) -> None:
    s = SymbolicScene.of(house)
    assert [(r.id, r.name) for r in s.rooms] == [(1, "kitchen"), (2, "livingroom"), (3, "bedroom")]
    assert s.room_named("bedroom").id == 3
    with pytest.raises(UnknownNameError, match="kitchen"):
        s.room_named("kitchn")
    containers = {c.class_name: (c.openable, c.is_open) for c in s.containers}
    # A book, a milk carton and a door can be opened but are not containers.
    assert containers == {"fridge": (True, False), "kitchencabinet": (True, True),
                          "sink": (False, True), "closet": (True, False), "box": (True, True)}
    assert set(s.surfaces) == {11, 12, 21, 30, 31, 43}
    assert set(s.grabbables) == {20, 21, 22, 23, 24, 32, 41, 42, 44}

    def where(i: int) -> tuple[int | None, int | None, str | None]:
        p = s.placement(i)
        return p.room, p.parent, None if p.relation is None else str(p.relation)

    assert where(20) == (1, 10, "INSIDE")  # milk in the fridge
    assert where(22) == (1, 12, "ON")  # cup on the table
    assert where(24) == (1, 11, "INSIDE")  # cupcake: INSIDE the cabinet beats ON the plate
    assert where(42) == (3, 41, "INSIDE")  # book: the box, not the closet around it
    assert where(12) == (1, None, None)
    assert where(33) == (2, None, None)  # a door in two rooms: the one whose box holds it
    assert where(100) == (2, None, None)
    assert s.enclosing_containers(42) == (41, 40)
    assert not s.is_reachable(42) and not s.is_reachable(20)
    assert s.is_reachable(24) and s.is_reachable(22)
    assert s.position(100) == (5.5, 0.0, 0.5)  # from obj_transform: no bounding box
    assert s.position(1) == (0.0, 1.5, 0.0)
    assert s.room_of(1) == 1
    assert set(s.contents(12)) == {22, 23}
    json.dumps(s.to_json())
    with pytest.raises(UnknownNameError):
        s.placement(1)


def test_round_trip_file(house: SceneGraph, tmp_path: Path) -> None:
    out = tmp_path / "house.json"
    house.save(out)
    again = SceneGraph.load(out)
    assert again == house
    assert SymbolicScene.of(again) == SymbolicScene.of(house)
    assert [p.name for p in tmp_path.iterdir()] == ["house.json"]  # no temp file left behind
    node = again.node(44)
    assert node.prefab_name == "PRE_PRO_Pillow_01" and node.obj_transform is not None


def test_unknown_node_keys_are_kept(tmp_path: Path) -> None:
    obj = house_json()
    obj["nodes"][0]["my_tag"] = {"a": [1, 2]}
    graph = SceneGraph.from_json(obj)
    assert graph.to_json()["nodes"][0]["my_tag"] == {"a": [1, 2]}


def test_save_to_missing_folder_is_a_clear_error(house: SceneGraph, tmp_path: Path) -> None:
    with pytest.raises(SceneGraphError, match="folder exists"):
        house.save(tmp_path / "nope" / "g.json")


def test_nodes_and_edges_validate_on_construction() -> None:
    with pytest.raises(SceneGraphError, match="class_name"):
        Node(1, "")
    with pytest.raises(SceneGraphError, match="Did you mean 'INSIDE'"):
        Edge(1, "INSIDES", 2)  # type: ignore[arg-type]
    with pytest.raises(SceneGraphError, match="negative"):
        BoundingBox((0, 0, 0), (1, -1, 1))
    assert Edge(1, "ON", 2).relation_type is Relation.ON  # type: ignore[arg-type]
    with pytest.raises(SceneGraphError, match="node 3"):
        SceneGraph((Node(1, "a"),), (Edge(1, Relation.ON, 3),))


# ---------------------------------------------------------------- the real apartments


@needs_virtualhome
def test_real_apartment_rooms_and_containers(apartment: SceneGraph) -> None:
    assert (len(apartment.nodes), len(apartment.edges)) == (356, 630)
    s = SymbolicScene.of(apartment)
    assert {r.name for r in s.rooms} == {"kitchen", "bathroom", "bedroom", "livingroom"}
    fridge = s.container(165)
    assert fridge is not None and fridge.class_name == "fridge"
    assert fridge.openable and not fridge.is_open
    cabinets = [c for c in s.containers if c.class_name == "kitchencabinet"]
    assert len(cabinets) == 8 and all(c.openable and not c.is_open for c in cabinets)
    bookshelf = s.container(246)
    assert bookshelf is not None and not bookshelf.openable and bookshelf.is_open
    assert s.container(53) is None  # an open door is not a container
    assert s.is_surface(130) and apartment.node(130).class_name == "kitchentable"
    assert len(s.grabbables) == 146
    assert all(p.room is not None for p in s.placements)


@needs_virtualhome
def test_real_apartment_object_locations(apartment: SceneGraph) -> None:
    s = SymbolicScene.of(apartment)
    kitchen = s.room_named("kitchen").id

    def where(i: int) -> tuple[str, str | None, str | None]:
        p = s.placement(i)
        parent = None if p.parent is None else apartment.node(p.parent).class_name
        return apartment.node(i).class_name, str(p.relation) if p.relation else None, parent

    assert where(1003) == ("plate", "INSIDE", "fridge")
    assert s.room_of(1003) == kitchen and not s.is_reachable(1003)
    assert where(195) == ("milk", "ON", "kitchentable")
    assert s.room_of(195) == kitchen and s.is_reachable(195)
    # mouse ON desk and ON mousemat (which is ON the desk): the mousemat is innermost.
    assert where(286) == ("mouse", "ON", "mousemat")
    # a stack of bowls: 94 ON 96, 97, 98 and 96 ON 98: the top-most support wins.
    assert s.placement(94).parent == 96
    # salmon ON the oven tray and INSIDE the stove: INSIDE is preferred.
    assert where(1012) == ("salmon", "INSIDE", "stove")
    assert where(163) == ("breadslice", "INSIDE", "toaster") and s.is_reachable(163)
    assert s.position(165) == apartment.node(165).bounding_box.center  # type: ignore[union-attr]


@needs_virtualhome
def test_second_apartment_quirks(apartment2: SceneGraph) -> None:
    s = SymbolicScene.of(apartment2)
    assert {r.name for r in s.rooms} == {"kitchen", "bathroom", "bedroom", "livingroom"}
    assert any(c.class_name == "kitchencabinets" for c in s.containers)
    # kitchencounter 93 is INSIDE the (smaller) dishwasher 105 in the data; that edge is
    # ignored, so the fruit on the counter stays reachable.
    assert (s.placement(93).relation, s.placement(93).parent) == (Relation.ON, 20)
    assert s.placement(50).parent == 93 and s.is_reachable(50)
    assert s.placement(377).parent == 104 and not s.is_reachable(377)  # pudding in the fridge
    assert s.placement(1).room is None  # the character has no edges at all
    assert apartment2.node(12).bounding_box is None and s.position(12) == (0.0, 0.0, 0.0)


@needs_virtualhome
@pytest.mark.parametrize("name", ["apartment_graph.json", "apartment_graph_2.json"])
def test_real_round_trip(name: str, tmp_path: Path) -> None:
    graph = SceneGraph.load(VIRTUALHOME / name)
    graph.save(tmp_path / name)
    again = SceneGraph.load(tmp_path / name)
    assert again == graph and SymbolicScene.of(again) == SymbolicScene.of(graph)
    if name == "apartment_graph.json":  # every key present in the source: nothing lost
        assert again.to_json() == json.loads((VIRTUALHOME / name).read_text())


# ---------------------------------------------------------------- malformed graphs


def mutated(change: Any) -> dict[str, Any]:
    obj = house_json()
    change(obj)
    return obj


def _node(obj: dict[str, Any], node_id: int) -> dict[str, Any]:
    return next(n for n in obj["nodes"] if n["id"] == node_id)


MALFORMED = {
    "top level is a list": ([], "JSON object"),
    "no nodes": ({"edges": []}, "'nodes'"),
    "wrapped graph": ({"graph": {"nodes": [], "edges": []}}, "wrapped in 'graph'"),
    "edges not a list": ({"nodes": [], "edges": {}}, "'edges' must be a list"),
    "node not an object": ({"nodes": [3], "edges": []}, r"nodes\[0\]"),
    "missing id": (mutated(lambda o: _node(o, 20).pop("id")), "class_name 'milk'.*no 'id'"),
    "string id": (mutated(lambda o: _node(o, 20).update(id="20")), "non-integer id '20'"),
    "float id": (mutated(lambda o: _node(o, 20).update(id=20.5)), "non-integer id 20.5"),
    "bool id": (mutated(lambda o: _node(o, 20).update(id=True)), "non-integer id True"),
    "duplicate id": (mutated(lambda o: _node(o, 21).update(id=20)), "duplicate node id 20"),
    "missing class_name": (mutated(lambda o: _node(o, 22).pop("class_name")), "node 22.*class_name"),
    "empty class_name": (mutated(lambda o: _node(o, 22).update(class_name="")), "node 22.*class_name"),
    "properties a string": (mutated(lambda o: _node(o, 23).update(properties="GRABBABLE")),
                            "node 23.*properties must be a list of strings"),
    "states with a number": (mutated(lambda o: _node(o, 23).update(states=["OPEN", 3])),
                             "node 23.*states must be a list of strings"),
    "open and closed": (mutated(lambda o: _node(o, 10).update(states=["OPEN", "CLOSED"])),
                        "node 10.*both OPEN and CLOSED"),
    "category a number": (mutated(lambda o: _node(o, 23).update(category=7)), "node 23.*category"),
    "bad bounding box": (mutated(lambda o: _node(o, 24).update(bounding_box={"center": [0, 1]})),
                         "node 24.*bounding_box"),
    "nan in bounding box": (mutated(lambda o: _node(o, 24)["bounding_box"].update(
        size=[1, float("nan"), 1])), "node 24.*finite"),
    "obj_transform a list": (mutated(lambda o: _node(o, 24).update(obj_transform=[1, 2])),
                             "node 24.*obj_transform"),
    "dangling to_id": (mutated(lambda o: o["edges"].append(
        {"from_id": 20, "relation_type": "ON", "to_id": 777})), "node 777, which does not exist"),
    "dangling from_id": (mutated(lambda o: o["edges"].append(
        {"from_id": 778, "relation_type": "ON", "to_id": 20})), "node 778"),
    "unknown relation": (mutated(lambda o: o["edges"].append(
        {"from_id": 20, "relation_type": "UNDER", "to_id": 12})), r"\(20 UNDER 12\).*unknown relation"),
    "lower-case relation": (mutated(lambda o: o["edges"].append(
        {"from_id": 20, "relation_type": "on", "to_id": 12})), "Did you mean 'ON'"),
    "edge id a string": (mutated(lambda o: o["edges"].append(
        {"from_id": "20", "relation_type": "ON", "to_id": 12})), "from_id must be an integer"),
    "edge lacks to_id": (mutated(lambda o: o["edges"].append({"from_id": 20, "relation_type": "ON"})),
                         "lacks to_id"),
    "inside cycle": (mutated(lambda o: o["edges"].append(
        {"from_id": 40, "relation_type": "INSIDE", "to_id": 42})), "INSIDE cycle between nodes .*40"),
    "inside self loop": (mutated(lambda o: o["edges"].append(
        {"from_id": 41, "relation_type": "INSIDE", "to_id": 41})), "INSIDE cycle between nodes 41"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_graph_names_the_culprit(case: str) -> None:
    obj, pattern = MALFORMED[case]
    with pytest.raises(SceneGraphError, match=pattern):
        SceneGraph.from_json(obj)


def test_inside_cycle_lists_every_id() -> None:
    obj = mutated(lambda o: o["edges"].append({"from_id": 40, "relation_type": "INSIDE", "to_id": 42}))
    with pytest.raises(SceneGraphError) as err:
        SceneGraph.from_json(obj)
    assert all(str(i) in str(err.value) for i in (40, 41, 42))


def test_on_cycles_are_tolerated() -> None:
    # VirtualHome derives ON from boxes and can make it mutual; the view must still come out.
    obj = mutated(lambda o: o["edges"].extend([{"from_id": 22, "relation_type": "ON", "to_id": 23},
                                               {"from_id": 23, "relation_type": "ON", "to_id": 22}]))
    s = SymbolicScene.of(SceneGraph.from_json(obj))
    assert s.room_of(22) == 1 and s.placement(22).parent in (12, 23)


@pytest.mark.parametrize(("text", "pattern"), [
    ('{"nodes": [\n  {"id": 1,}\n], "edges": []}', "not valid JSON.*line 2, column"),
    ("", "not valid JSON.*line 1, column 1"),
    ("[" * 100_000 + "]" * 100_000, "too deeply|not valid JSON|not a usable"),
    ('{"nodes": [{"id": ' + "9" * 5000 + ', "class_name": "x"}], "edges": []}', "not a usable"),
    ('{"nodes": NaN, "edges": []}', "'nodes' must be a list"),
])
def test_bad_json_text(tmp_path: Path, text: str, pattern: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(SceneGraphError, match=pattern):
        SceneGraph.load(path)


def test_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "latin1.json"
    path.write_bytes(b'{"nodes": [{"id": 1, "class_name": "caf\xe9"}], "edges": []}')
    with pytest.raises(SceneGraphError, match="not UTF-8.*offset"):
        SceneGraph.load(path)


def test_huge_file_is_refused_before_reading(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "huge.json"
    with path.open("wb") as fh:
        fh.truncate(200 * MIB)  # sparse: 200 MB on paper, nothing on disk
    real_open = Path.open

    def never_this_one(self: Path, *args: Any, **kwargs: Any) -> Any:  # refused from its size alone
        if self == path:
            raise AssertionError(f"{path} was opened")
        return real_open(self, *args, **kwargs)

    monkeypatch.setattr(Path, "open", never_this_one)
    with pytest.raises(SceneGraphError, match=r"200\.0 MB.*50\.0 MB limit.*max_bytes"):
        SceneGraph.load(path)


def test_size_limit_is_an_input(tmp_path: Path) -> None:
    with pytest.raises(SceneGraphError, match="limit"):
        SceneGraph.load(HOUSE, max_bytes=100)


def test_directory_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(SceneGraphError, match="is a directory"):
        SceneGraph.load(tmp_path)
    with pytest.raises(SceneGraphError, match="no such file"):
        SceneGraph.load(tmp_path / "missing.json")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_special_file_is_refused(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(SceneGraphError, match="not a regular file"):
        SceneGraph.load(fifo)  # would block forever if it were opened


# ---------------------------------------------------------------- property-based

CLASSES = ("kitchen", "fridge", "plate", "table", "cup", "box")
PROPS = ("GRABBABLE", "CONTAINERS", "SURFACES", "CAN_OPEN", "MOVABLE")
finite = st.floats(-50, 50, allow_nan=False)
boxes = st.none() | st.builds(lambda c, s: {"center": c, "size": s},
                              st.lists(finite, min_size=3, max_size=3),
                              st.lists(st.floats(0, 10), min_size=3, max_size=3))


@st.composite
def valid_graphs(draw: st.DrawFn) -> dict[str, Any]:
    ids = draw(st.lists(st.integers(-5, 10**6), min_size=1, max_size=12, unique=True))
    nodes = []
    for i in ids:
        nodes.append({
            "id": i,
            "class_name": draw(st.sampled_from(CLASSES)),
            "category": draw(st.sampled_from(("Rooms", "Props", "Furniture", ""))),
            "properties": draw(st.lists(st.sampled_from(PROPS), unique=True, max_size=3)),
            "states": draw(st.sampled_from(([], ["OPEN"], ["CLOSED"], ["CLOSED", "OFF"]))),
            "bounding_box": draw(boxes),
            "prefab_name": draw(st.none() | st.text(max_size=5)),
            "obj_transform": draw(st.none() | st.just({"position": [1.0, 0.0, 2.0]})),
        })
    edges = []
    for _ in range(draw(st.integers(0, 20))):
        a, b = draw(st.integers(0, len(ids) - 1)), draw(st.integers(0, len(ids) - 1))
        rel = draw(st.sampled_from(list(Relation)))
        if rel is Relation.INSIDE:  # keep INSIDE acyclic: only towards earlier nodes
            if a == b:
                continue
            a, b = max(a, b), min(a, b)
        edges.append({"from_id": ids[a], "relation_type": str(rel), "to_id": ids[b]})
    return {"nodes": nodes, "edges": edges}


def check_view(graph: SceneGraph) -> None:
    s = SymbolicScene.of(graph)
    room_ids = {r.id for r in s.rooms}
    assert {p.id for p in s.placements} | room_ids == {n.id for n in graph.nodes}
    for p in s.placements:
        assert p.room is None or p.room in room_ids
        assert (p.parent is None) == (p.relation is None)
        assert p.parent is None or (p.parent in graph and p.parent not in room_ids)
        s.enclosing_containers(p.id)
        s.is_reachable(p.id)
    json.dumps(s.to_json())


@given(valid_graphs())
@settings(max_examples=60, deadline=None)
def test_valid_graphs_round_trip(obj: dict[str, Any]) -> None:
    graph = SceneGraph.from_json(obj)
    again = SceneGraph.from_json(json.loads(json.dumps(graph.to_json())))
    assert again == graph
    check_view(graph)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=4),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner,
                                                               max_size=3),
    max_leaves=6,
)


def _paths(obj: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += _paths(v, (*prefix, i))
    return out


@given(valid_graphs(), st.data())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_mutations_only_raise_scene_graph_errors(obj: dict[str, Any], data: st.DataObject) -> None:
    obj = copy.deepcopy(obj)
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(_paths(obj)))
        if not path:
            obj = data.draw(json_values)
            continue
        parent = obj
        for key in path[:-1]:
            parent = parent[key]
        action = data.draw(st.sampled_from(("replace", "delete", "duplicate")))
        if action == "replace":
            parent[path[-1]] = data.draw(json_values)
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent, list):
            parent.append(copy.deepcopy(parent[path[-1]]))
    try:
        graph = SceneGraph.from_json(obj)
    except SceneGraphError:
        return
    check_view(graph)


@given(st.binary(max_size=200) | st.text(max_size=200).map(str.encode))
@settings(max_examples=100, deadline=None)
def test_random_bytes_only_raise_scene_graph_errors(blob: bytes) -> None:
    with contextlib.suppress(SceneGraphError):
        SceneGraph.parse(blob)


# ---------------------------------------------------------------- CLI


@pytest.mark.parametrize("columns", ["80", "50"])
def test_cli_inspect_text(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, columns: str) -> None:
    """What the text says does not depend on the terminal's width or on how long the path is."""
    from click.testing import CliRunner

    monkeypatch.setenv("COLUMNS", columns)
    far = tmp_path / ("a-long-folder-name-" * 4) / "[draft] scenes"  # long, with markup-like brackets
    far.mkdir(parents=True)
    scene = far / HOUSE.name
    shutil.copy(HOUSE, scene)
    result = CliRunner().invoke(root, ["scene", "inspect", str(scene)])
    assert result.exit_code == 0, result.output
    first = result.output.splitlines()[0]
    assert first.startswith(f"{scene}: 22 nodes, 36 edges, 3 rooms")  # the path in full, one line
    for word in ("kitchen", "bedroom", "fridge", "closed", "kitchentable", "kitchencabinet",
                 "remotecontrol", "livingroom"):
        assert word in result.output
    assert "\u2026" not in result.output  # no name shortened with an ellipsis


def test_cli_inspect_json() -> None:
    from click.testing import CliRunner

    result = CliRunner().invoke(root, ["scene", "inspect", str(HOUSE), "--json"])
    assert result.exit_code == 0, result.output
    info = json.loads(result.output)
    assert {"rooms", "containers", "surfaces", "objects_by_class", "num_nodes",
            "num_edges"} <= set(info)
    assert (info["num_nodes"], info["num_edges"]) == (22, 36)
    assert [r["name"] for r in info["rooms"]] == ["kitchen", "livingroom", "bedroom"]
    fridge = next(c for c in info["containers"] if c["class_name"] == "fridge")
    assert fridge["open"] is False and fridge["room_name"] == "kitchen"
    assert info["objects_by_class"]["cup"] == 1


@needs_virtualhome
def test_cli_inspect_real_apartment_json() -> None:
    from click.testing import CliRunner

    result = CliRunner().invoke(root, ["scene", "inspect", str(VIRTUALHOME / "apartment_graph.json"),
                                       "--json"])
    info = json.loads(result.output)
    assert (info["num_nodes"], info["num_edges"]) == (356, 630)
    assert info["objects_by_class"]["cutleryfork"] == 5


@pytest.mark.parametrize(("make", "pattern"), [
    (lambda d: d, "is a directory"),
    (lambda d: d / "missing.json", "no such file"),
    (lambda d: (d / "x.json").write_text("{oops") and d / "x.json", "not valid JSON"),
])
def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], make: Any,
                                 pattern: str) -> None:
    assert main(["scene", "inspect", str(make(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert re.search(pattern, err)


def test_errors_are_siftom_errors() -> None:
    assert issubclass(SceneGraphError, SiftomError)
