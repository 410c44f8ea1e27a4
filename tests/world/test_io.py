"""Bring your own scene: siftom's world JSON and VirtualHome graphs become a world, a state and goals."""

import json
from pathlib import Path

import pytest

from siftom.errors import ObservationError
from siftom.world.io import load_scene, scene_from_json, scene_warnings
from siftom.world.model import NOTHING

FIXTURE = Path(__file__).parents[1] / "fixtures" / "scene_three_rooms.json"
VIRTUALHOME = Path(__file__).parents[2] / "data" / "virtualhome" / "apartment_graph.json"

WORLD = {
    "places": [{"name": "table", "kind": "surface", "room": "dining", "pos": [0, 0]},
               {"name": "drawer", "kind": "container", "room": "kitchen", "pos": [5, 1], "closable": True}],
    "doors": [{"rooms": ["dining", "kitchen"], "pos": [2, 0]}],
    "items": [{"name": "fork_1", "class": "fork", "at": "drawer"}, {"name": "fork_2", "class": "fork", "at": "drawer"}],
    "agents": {"human": "drawer", "robot": "table"},
    "open": ["drawer"],
    "target": "table",
    "goals": [{"name": "forks", "counts": {"fork": 2}}, {"name": "spoons", "counts": {"spoon": 1}}],
}


def test_world_json_loads_layout_state_and_feasible_goals():
    scene = scene_from_json(WORLD)
    w = scene.world
    assert [p.name for p in w.places] == ["table", "drawer"]
    assert w.places[1].closable and scene.start.is_open(1)
    assert scene.start.agent_at == (1, 0) and scene.start.held == (NOTHING, NOTHING)
    assert scene.start.item_at == (1, 1)
    assert w.dist[0, 1] == 2 + 4  # through the door: 2 m + sqrt(9 + 1) m, each leg rounded up together
    assert [g.name for g in scene.goals] == ["forks"]  # spoons are not in the scene: dropped
    assert scene.verb == "deliver"


def test_world_json_can_name_a_built_in_goal_space():
    scene = scene_from_json({**{k: v for k, v in WORLD.items() if k != "goals"}, "goal_space": "kitchen-v0",
                             "items": [{"name": "milk", "class": "milk", "at": "drawer"},
                                       {"name": "cereal", "class": "cereal", "at": "drawer"},
                                       {"name": "bowl", "class": "bowl", "at": "table"}]})
    assert [g.name for g in scene.goals] == ["breakfast_cereal"] and scene.verb == "fetch"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"target": "tabel"}, "Did you mean 'table'"),
        ({"places": []}, "'places' must be a non-empty list"),
        ({"items": [{"name": "fork_1", "class": "fork", "at": "sofa"}]}, "items\\[0\\]: unknown place 'sofa'"),
        ({"items": [{"name": "fork_1", "at": "drawer"}]}, "items\\[0\\]: missing 'class'"),
        ({"goals": [{"name": "x", "counts": {"fork": 3}}]}, "no goal in the goal space can be reached"),
        ({"goals": [{"name": "x", "counts": {}}]}, "counts must be an object"),
        ({"goal_space": "chess-v0", "goals": None}, "goal_space must be"),
        ({"doors": [{"rooms": ["dining"], "pos": [0, 0]}]}, "rooms must be a list of two room names"),
    ],
)
def test_world_json_errors_name_the_field(change, message):
    obj = {**WORLD, **change}
    if obj.get("goals") is None:
        obj.pop("goals")
    with pytest.raises(ObservationError, match=message):
        scene_from_json(obj)


def test_load_scene_file_errors(tmp_path):
    with pytest.raises(ObservationError, match="no such file"):
        load_scene(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ObservationError, match="not (valid )?JSON"):
        load_scene(bad)
    good = tmp_path / "world.json"
    good.write_text(json.dumps(WORLD))
    assert load_scene(good).world.items[0].name == "fork_1"


def test_a_virtualhome_graph_without_enough_objects_for_any_goal_says_so():
    # the fixture has one milk, one cup, one fork and one plate: no recipe, no table setting
    with pytest.raises(ObservationError, match="no goal in the goal space can be reached"):
        load_scene(FIXTURE, goal_space="kitchen-v0", target="kitchentable")


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_the_virtualhome_apartment_loads_with_the_household_goal_space():
    scene = load_scene(VIRTUALHOME)
    assert "fork" in scene.world.classes and len(scene.goals) > 0
    assert all(g.target == scene.start.agent_at[0] for g in scene.goals)


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_objects_the_goal_space_cannot_use_are_reported_not_dropped_silently():
    scene = load_scene(VIRTUALHOME)
    left_out = [n for n in scene.notes if "left out" in n and "no household-table-v0 goal uses" in n]
    assert left_out, scene.notes
    assert "book x7" in left_out[0] and "'goals'" in left_out[0]  # names the classes and the fix
    assert any("rest on no furniture" in n and "cutleryknife x2" in n for n in scene.notes)
    obj = json.loads(VIRTUALHOME.read_text())
    assert scene_warnings(obj, scene)[: len(scene.notes)] == list(scene.notes)


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_a_goals_list_in_the_graph_keeps_objects_of_any_class(tmp_path):
    obj = json.loads(VIRTUALHOME.read_text())
    obj["goals"] = [{"name": "bedtime", "counts": {"pillow": 2}}, {"name": "read", "counts": {"book": 1}}]
    path = tmp_path / "graph.json"
    path.write_text(json.dumps(obj))
    scene = load_scene(path, target="kitchentable")
    assert {"pillow", "book"} <= set(scene.world.classes)
    assert {g.name for g in scene.goals} == {"bedtime", "read"}
    unused = next(n for n in scene.notes if "no given goal uses" in n)
    assert "pillow" not in unused and "book" not in unused


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_the_kitchen_goal_space_keeps_foods_named_as_in_virtualhome():
    scene = load_scene(VIRTUALHOME, goal_space="kitchen-v0", target="kitchencounter")
    assert "apple" in scene.world.classes  # VirtualHome's own class name, used by kitchen-v0 goals
