"""VirtualHome script lines become the same siftom actions as siftom's own form."""

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from siftom.errors import ObservationError
from siftom.scenarios.base import get_scenario
from siftom.world.io import load_scene, scene_from_json, scene_warnings, unmentioned_class_warnings
from siftom.world.model import NOTHING
from siftom.world.vhscript import is_vh_line, parse_actions

ROOT = Path(__file__).parents[2]
VIRTUALHOME = ROOT / "data" / "virtualhome" / "apartment_graph.json"
SALAD = ROOT / "docs" / "examples" / "salad"
needs_graph = pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"needs {VIRTUALHOME}")


def _as_vh(world, a) -> str:
    """An independent writer of VirtualHome lines for siftom actions (names, no graph ids)."""
    if a.kind == "walk":
        return f"[Walk] <{world.places[a.place].name}> (1)"
    if a.kind in ("open", "close"):
        return f"[{a.kind.title()}] <{world.places[a.place].name}> (1)"
    if a.kind == "grab":
        return f"[Grab] <{world.items[a.obj].name}> (1)"
    return f"[PutBack] <{world.items[a.obj].name}> (1) <{world.places[a.place].name}> (2)"


@pytest.mark.parametrize("sid", ["household-table-v0/0", "household-table-v0/5", "kitchen-v0/2", "kitchen-cereal-v0"])
def test_script_lines_of_a_recorded_scenario_give_its_actions(sid):
    sc = get_scenario(sid)
    lines = [_as_vh(sc.world, a) for a in sc.actions]
    assert all(is_vh_line(x) for x in lines)
    acts, end = parse_actions(sc.world, sc.start, lines)
    assert acts == list(sc.actions)
    assert end == sc.now
    # both formats mixed in one list
    mixed = [sc.world.format_action(a) if k % 2 else line for k, (a, line) in enumerate(zip(sc.actions, lines, strict=True))]
    assert parse_actions(sc.world, sc.start, mixed)[0] == list(sc.actions)


@needs_graph
def test_scene_graph_ids_map_to_places_and_objects():
    scene = load_scene(VIRTUALHOME)
    w = scene.world
    lines = ["<char0> [Walk] <kitchen> (56)", "[Walk] <dishwasher> (159)", "[Open] <dishwasher> (159)",
             "[Grab] <cutleryfork> (1006)", "[LookAt] <kitchentable> (130)",
             "[PutBack] <cutleryfork> (1006) <kitchentable> (130)", "[Grab] <cutleryfork> (1007)"]
    acts, end = parse_actions(w, scene.start, lines)
    assert [w.format_action(a) for a in acts] == [
        "walk(human, dishwasher.159)", "open(human, dishwasher.159)",
        "grab(human, cutleryfork.1006, dishwasher.159)",
        "walk(human, kitchentable.130)", "put(human, cutleryfork.1006, kitchentable.130)",
        "walk(human, dishwasher.159)", "grab(human, cutleryfork.1007, dishwasher.159)"]  # walks inserted
    assert end.held[0] == w.item("cutleryfork.1007") and end.held[1] == NOTHING


@needs_graph
@pytest.mark.parametrize("line, words", [
    ("[Grab] <mug> (999)", "no place or object of this world has scene-graph id 999"),
    ("[Grab] <plate> (261)", "node 261 is 'mug.261', not a 'plate'"),
    ("[SwitchOn] <stove> (157)", "[SwitchOn] has no counterpart"),
    ("<char1> [Walk] <fridge> (165)", "only the human's actions"),
    ("[Grab] <plate> (1003)", "fridge.165 is closed; open it first"),
    ("[PutBack] <mug> (261)", "takes an object and a place"),
    ("Walk to the fridge", "cannot parse action"),
])
def test_unmappable_script_lines_say_why(line, words):
    scene = load_scene(VIRTUALHOME)
    with pytest.raises(ObservationError) as exc:
        parse_actions(scene.world, scene.start, [line])
    assert words in str(exc.value)


def test_class_no_goal_mentions_gets_a_warning_naming_near_classes(tmp_path):
    world = json.loads((SALAD / "world.json").read_text())
    world["items"].append({"name": "tomatoes_1", "class": "tomatoes", "at": "fridge"})
    scene = scene_from_json(world)
    warns = scene_warnings(world, scene)
    assert len(warns) == 1 and "'tomatoes'" in warns[0] and "nearest goal-library classes: tomato" in warns[0]
    assert unmentioned_class_warnings(scene_from_json(json.loads((SALAD / "world.json").read_text())).world,
                                      scene.goals) == []
    from siftom.cli import root

    path = tmp_path / "world.json"
    path.write_text(json.dumps(world))
    args = ["infer", "--scene", str(path), "--transcript", "the tomato please"]
    res = CliRunner().invoke(root, [*args, "--json"], catch_exceptions=False)
    assert json.loads(res.output)["warnings"] == warns  # --json: a field, stdout stays JSON
    res = CliRunner().invoke(root, args, catch_exceptions=False)
    assert f"warning: {warns[0]}" in res.output


def test_the_salad_example_runs_and_actions_beat_the_misheard_word():
    """docs/examples/salad: "potato" heard for "tomato"; the salad in progress makes it fetch(tomato)."""
    runner = CliRunner()
    from siftom.cli import root

    for actions in ("actions.txt", "actions_vh.txt"):
        res = runner.invoke(root, ["infer", "--scene", str(SALAD / "world.json"), "--actions", str(SALAD / actions),
                                   "--transcript", "can you get me the potato", "--json"], catch_exceptions=False)
        assert res.exit_code == 0, res.output
        out = json.loads(res.stdout)
        assert out["command"] == "fetch(tomato)" and out["action"] == "act" and out["goals"][0]["goal"] == "salad"
    res = runner.invoke(root, ["infer", "--scene", str(SALAD / "world.json"), "--actions", str(SALAD / "actions.txt"),
                               "--transcript", "can you get me the potato", "--model", "speech-only", "--json"])
    assert json.loads(res.stdout)["top_command"] == "fetch(potato)"  # words alone take the wrong item
