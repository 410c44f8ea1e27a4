"""Scene graph -> world JSON, goal checks and the library merge, against independent references."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helpers import three_room_house
from siftom.errors import PerceptionError
from siftom.perception.scene import graph_from_world, parse_scene
from siftom.perception.validate import (
    GoalProposal,
    NamedGoal,
    check_goals,
    library_goals,
    merge_goals,
)
from siftom.scenarios.base import get_scenario
from siftom.world.io import scene_from_json


@pytest.mark.parametrize("sid", ["kitchen-cereal-v0", "household-table-v0/3"])
def test_a_perfect_graph_gives_back_the_scenario(sid):
    sc = get_scenario(sid)
    world = parse_scene(graph_from_world(sc.world, sc.start).to_json()).world
    ref = sc.to_json()  # the scenario's own description, an independent path
    assert [(p["name"], p["kind"], p["room"], p["pos"], p["closable"]) for p in world["places"]] == \
        [(p["name"], p["kind"], p["room"], p["pos"], p["closable"]) for p in ref["places"]]
    assert sorted((i["name"], i["class"], i["at"]) for i in world["items"]) == \
        sorted((o["name"], o["class"], o["at"]) for o in ref["objects"])
    assert world["agents"] == ref["agents"]
    assert sorted(world["open"]) == sorted(p["name"] for p in ref["places"] if p["open"])
    # same walking costs within a room (a scene graph has no doors, so rooms are linked straight through)
    loaded = scene_from_json({**world, "target": ref["target"], "goals": [{"name": "g", "counts": {sc.goal.counts[0][0]: 1}}]})
    for a, pa in enumerate(sc.world.places):
        for b, pb in enumerate(sc.world.places):
            if pa.room == pb.room:
                assert loaded.world.dist[a, b] == sc.world.dist[a, b]

def test_names_classes_and_open_states():
    g = {"nodes": [
        {"id": 1, "class_name": "Kitchen", "category": "Rooms"},
        {"id": 10, "class_name": "kitchen counter", "properties": ["SURFACES"]},
        {"id": 11, "class_name": "fridge", "properties": ["CONTAINERS", "CAN_OPEN"], "states": ["OPEN"]},
        {"id": 20, "class_name": "cutleryfork", "properties": ["GRABBABLE"]},
        {"id": 21, "class_name": "cutleryfork", "properties": ["GRABBABLE"]},
        {"id": 22, "class_name": "milk", "properties": ["GRABBABLE"]},
        {"id": 90, "class_name": "character"}],
        "edges": [{"from_id": 10, "relation_type": "INSIDE", "to_id": 1},
                  {"from_id": 11, "relation_type": "INSIDE", "to_id": 1},
                  {"from_id": 20, "relation_type": "ON", "to_id": 10},
                  {"from_id": 21, "relation_type": "ON", "to_id": 20},  # stacked on the other fork
                  {"from_id": 22, "relation_type": "INSIDE", "to_id": 11},
                  {"from_id": 90, "relation_type": "CLOSE", "to_id": 11}]}
    w = parse_scene(g).world
    assert [p["name"] for p in w["places"]] == ["kitchen_counter", "fridge"]
    assert w["items"] == [{"name": "fork_1", "class": "fork", "at": "kitchen_counter"},
                          {"name": "fork_2", "class": "fork", "at": "kitchen_counter"},
                          {"name": "milk", "class": "milk", "at": "fridge"}]
    assert w["open"] == ["fridge"] and w["agents"] == {"human": "fridge", "robot": "fridge"}
    no_person = {**g, "nodes": g["nodes"][:-1], "edges": g["edges"][:-1]}
    with pytest.raises(PerceptionError, match="no person"):
        parse_scene(no_person)
    no_room = {"nodes": [n for n in g["nodes"] if n["id"] != 1], "edges": [e for e in g["edges"] if e["to_id"] != 1]}
    with pytest.raises(PerceptionError, match="no room"):
        parse_scene(no_room)


def test_goals_are_checked_and_merged_with_the_library():
    world, _ = three_room_house()
    target, goals = check_goals(world, GoalProposal.from_json({"target": "table", "goals": [
        {"name": "forks", "counts": [{"class": "fork", "count": 2}]},
        {"name": "meal", "counts": [{"class": "plate", "count": 1}, {"class": "fork", "count": 1}]}]}))
    assert target == "table" and goals[1].to_json() == {"name": "meal", "counts": {"plate": 1, "fork": 1}}
    with pytest.raises(PerceptionError, match="lists 'fork' twice"):
        check_goals(world, GoalProposal.from_json({"target": "table", "goals": [
            {"name": "f", "counts": [{"class": "fork", "count": 1}, {"class": "fork", "count": 1}]}]}))
    library = [NamedGoal("forks", (("plate", 1),)), NamedGoal("two_forks", (("fork", 2),))]
    merged = merge_goals(goals, library)
    assert merged == [*library, NamedGoal("meal", (("plate", 1), ("fork", 1)))]  # same counts = same goal
    assert merge_goals([NamedGoal("forks", (("cup", 1),))], library)[-1].name == "forks_proposed"


def test_library_goals_are_only_the_reachable_ones():
    sc = get_scenario("kitchen-cereal-v0")
    lib = library_goals(sc.world, "kitchen-v0")
    assert len(lib) == len(sc.goals)  # every recipe is reachable in the full kitchen
    world, _ = three_room_house()
    assert library_goals(world, "kitchen-v0") == []  # no recipe can be made from forks, a plate and a cup
    with pytest.raises(Exception, match="kitchen-v0"):
        library_goals(world, "kitchen-v1")


def test_scenario_frames_are_distinct_pictures_and_steps_are_checked(frames, tmp_path, capsys):
    from siftom.cli import main

    data = [f.read_bytes() for f in frames]
    assert all(d.startswith(b"\x89PNG") for d in data) and len(set(data)) == len(data)
    assert main(["scenarios", "show", "kitchen-cereal-v0", "--step", "11", "--png", str(tmp_path / "x.png")]) == 2
    assert "step must be between 0 and 10" in capsys.readouterr().err


VIRTUALHOME = Path(__file__).parents[2] / "data" / "virtualhome"


@pytest.mark.skipif(not (VIRTUALHOME / "apartment_graph_2.json").exists(), reason="needs data/virtualhome/apartment_graph_2.json")
def test_a_real_apartment_is_a_known_world():
    from siftom.perception.pipeline import KnownWorld

    graph = json.loads((VIRTUALHOME / "apartment_graph_2.json").read_text())
    world = KnownWorld.from_json(graph).world  # 339 nodes: only furniture that holds objects or agents becomes a place
    assert len(world["places"]) <= 62 and len(world["items"]) > 50
    # the character has no edges; it stands at the furniture nearest to its position
    char = next(n for n in graph["nodes"] if n["class_name"] == "character")
    nearest = min(world["places"], key=lambda p: (p["pos"][0] - char["bounding_box"]["center"][0]) ** 2
                  + (p["pos"][1] - char["bounding_box"]["center"][2]) ** 2)
    assert world["agents"]["human"] == nearest["name"]
    loaded = scene_from_json({**world, "target": nearest["name"], "goals": [{"name": "g", "counts": {"apple": 1}}]})
    assert len(loaded.world.items) == len(world["items"])
    with pytest.raises(PerceptionError, match=r"and \d+ more"):  # a perceived scene must place every object
        parse_scene(graph)


def test_the_world_does_not_depend_on_how_the_model_writes_the_graph():
    """Shuffled nodes, other ids, VirtualHome class spellings, extra nodes and edges: same world."""
    import random

    sc = get_scenario("kitchen-cereal-v0")
    g = graph_from_world(sc.world, sc.start).to_json()
    rng = random.Random(3)
    ids = [n["id"] for n in g["nodes"]]
    new = dict(zip(ids, rng.sample(range(5000, 9000), len(ids)), strict=True))
    for n in g["nodes"]:
        n["id"] = new[n["id"]]
        if n["class_name"] == "bowl":
            n["class_name"] = "dishbowl"  # VirtualHome's name, mapped to siftom's class
        elif n["class_name"] == "kitchen_counter":
            n["class_name"] = "Kitchen Counter"
    for e in g["edges"]:
        e["from_id"], e["to_id"] = new[e["from_id"]], new[e["to_id"]]
    wall = {"id": 1, "class_name": "wall", "category": "Walls", "properties": [], "states": [],
            "bounding_box": {"center": [0, 1, 0], "size": [5, 2, 0.1]}}
    kitchen = next(n["id"] for n in g["nodes"] if n["class_name"] == "kitchen")
    g["nodes"].append(wall)
    g["edges"] += [{"from_id": 1, "relation_type": "INSIDE", "to_id": kitchen},
                   {"from_id": new[9000], "relation_type": "FACING", "to_id": 1}]
    rng.shuffle(g["nodes"])
    rng.shuffle(g["edges"])
    world = parse_scene(g).world
    ref = sc.to_json()
    assert sorted((i["class"], i["at"]) for i in world["items"]) == sorted((o["class"], o["at"]) for o in ref["objects"])
    assert sorted(p["name"] for p in world["places"]) == sorted(p["name"] for p in ref["places"])
    assert world["agents"] == ref["agents"]


@pytest.mark.parametrize("bad, words", [
    ({"agents": 3}, "the world is not valid"),
    ({"items": []}, "no movable objects"),
    ({"goals": [{"name": "g", "counts": ["fork"]}]}, "goals must be a list like"),
    ({"goals": {"fork": 2}}, "goals must be a list like"),
    ({"nodes": [{"id": "x"}], "edges": []}, "not a valid scene graph"),
])
def test_a_given_world_is_checked_before_any_request(bad, words):
    from siftom.perception.pipeline import KnownWorld

    good = {"places": [{"name": "table", "kind": "surface", "room": "r", "pos": [0, 0]}],
            "items": [{"name": "fork_1", "class": "fork", "at": "table"}], "target": "table"}
    assert KnownWorld.from_json(good).world["items"] == good["items"]
    with pytest.raises(PerceptionError, match=words):
        KnownWorld.from_json({**good, **bad})
