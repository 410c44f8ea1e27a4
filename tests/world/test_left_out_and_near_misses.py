"""VirtualHome graphs: left-out nodes are named as left out, and misspelt goal classes get a suggestion."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from siftom.errors import ObservationError
from siftom.world.io import scene_from_scenegraph
from siftom.world.scenegraph import SceneGraph
from siftom.world.vhscript import parse_actions

GRAPH = json.loads((Path(__file__).parents[2] / "data" / "virtualhome" / "apartment_graph.json").read_text())


def _id(cls: str) -> int:
    return next(n["id"] for n in GRAPH["nodes"] if n["class_name"] == cls)


def _scene(graph=GRAPH, **kw):
    return scene_from_scenegraph(SceneGraph.from_json(graph), **kw)


@pytest.mark.parametrize("line, words", [
    (f"[Grab] <book> ({_id('book')})", "was left out of this world: no household-table-v0 goal uses class 'book'"),
    (f"[Walk] <sofa> ({_id('sofa')})", "was left out of this world: it holds no object a goal uses"),
    ("[Grab] <milk> (999999)", "no place or object of this world has scene-graph id 999999"),
])
def test_a_left_out_node_is_reported_as_left_out(line, words):
    sc = _scene()
    with pytest.raises(ObservationError, match=words):
        parse_actions(sc.world, sc.start, [line], first=0)


def test_loose_objects_are_reported_as_resting_on_no_furniture():
    sc = _scene()
    loose = [nid for nid, why in sc.world.left_out.items() if "rests on no furniture" in why]
    assert loose, "the apartment graph has two loose knives"
    with pytest.raises(ObservationError, match="rests on no furniture"):
        parse_actions(sc.world, sc.start, [f"[Grab] <cutleryknife> ({loose[0]})"], first=0)


def test_a_graph_whose_classes_are_all_unknown_still_shows_what_was_left_out():
    odd = {**GRAPH, "nodes": [{**n, "class_name": "zz" + n["class_name"]} if "GRABBABLE" in n.get("properties", [])
                              else n for n in GRAPH["nodes"]]}
    with pytest.raises(ObservationError) as e:
        _scene(odd)
    assert "no goal in the goal space can be reached" in str(e.value)
    assert "left out" in str(e.value) and "zzbook" in str(e.value)


@pytest.mark.parametrize("cls, close", [("forks", "fork"), ("wineglas", "wineglass")])
def test_near_miss_goal_classes_get_did_you_mean(cls, close):
    with pytest.raises(ObservationError, match=f"did you mean '{close}'"):
        _scene(goals=[{"name": "x", "counts": {cls: 1}}])
