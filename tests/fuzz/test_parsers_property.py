"""Property tests: every parser of user input answers bad input with a SiftomError, never another exception.

World JSON, VirtualHome graphs and script lines, action strings, sweep TOML, vision-model answers
(hypothesis generates both arbitrary values and small mutations of valid inputs). The HTTP and
CLI sides are in test_boundaries_property.py. Example counts stay modest so the suite is fast.
"""

from __future__ import annotations

import copy
import json
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from siftom.errors import SiftomError

ROOT = Path(__file__).parents[2]
SALAD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
SMALL_GRAPH = json.loads((ROOT / "tests" / "fixtures" / "scene_three_rooms.json").read_text())
FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

scalars = st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True) | st.text(max_size=12)
json_values = st.recursive(scalars, lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c,
                                                                                       max_size=4), max_leaves=12)


def _paths(obj: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def mutated(draw: Any, base: Any) -> Any:
    """``base`` with one value (anywhere in it) replaced by an arbitrary JSON value, or deleted."""
    obj = copy.deepcopy(base)
    paths = [p for p in _paths(obj) if p]
    path = draw(st.sampled_from(paths))
    parent = obj
    for k in path[:-1]:
        parent = parent[k]
    if draw(st.booleans()) and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = draw(json_values)
    return obj


def _only_siftom_errors(fn: Any, *args: Any) -> None:
    try:
        fn(*args)
    except SiftomError as exc:
        assert str(exc), "an error must say what was wrong"


@FAST
@given(st.one_of(json_values, mutated(SALAD)))
def test_world_json(obj):
    from siftom.world.io import scene_from_json

    _only_siftom_errors(scene_from_json, obj)


@FAST
@given(st.one_of(json_values, mutated(SMALL_GRAPH)))
def test_virtualhome_graphs(obj):
    from siftom.world.io import scene_from_scenegraph
    from siftom.world.scenegraph import SceneGraph

    def load(o: Any) -> None:
        scene_from_scenegraph(SceneGraph.from_json(o), target="kitchentable", goal_space="kitchen-v0")

    _only_siftom_errors(load, obj)


@FAST
@given(st.binary(max_size=200) | st.text(max_size=200).map(str.encode))
def test_virtualhome_graph_text(data):
    from siftom.world.scenegraph import SceneGraph

    _only_siftom_errors(SceneGraph.parse, data)


_SCENE = None


def _salad():
    global _SCENE
    if _SCENE is None:
        from siftom.world.io import scene_from_json

        _SCENE = scene_from_json(SALAD)
    return _SCENE


script_lines = st.one_of(
    st.text(max_size=60),
    st.builds(lambda v, a, n, b, m: f"[{v}] <{a}> ({n})" + (f" <{b}> ({m})" if b else ""),
              st.sampled_from(["Walk", "Grab", "PutBack", "PutIn", "Open", "Close", "Run", "Find", "Eat", "x"]),
              st.sampled_from(["fridge", "tomato_1", "counter", "lettuce", "kitchen", ""]) | st.text(max_size=8),
              st.integers(-5, 10**30) | st.text(max_size=4),
              st.none() | st.sampled_from(["counter", "fridge"]) | st.text(max_size=6),
              st.integers(-5, 10**6)),
    st.builds(lambda v, args: f"{v}({', '.join(args)})",
              st.sampled_from(["walk", "grab", "put", "open", "close", "give", "x"]),
              st.lists(st.sampled_from(["human", "robot", "fridge", "tomato_1", "counter"]) | st.text(max_size=8),
                       max_size=4)),
)


@FAST
@given(st.lists(script_lines, min_size=1, max_size=4))
def test_script_lines_and_action_strings(lines):
    from siftom.world.vhscript import parse_actions

    sc = _salad()
    _only_siftom_errors(parse_actions, sc.world, sc.start, lines, 0)
    _only_siftom_errors(sc.world.parse_action, lines[0], sc.start)


toml_text = st.one_of(
    st.text(max_size=200),
    st.builds(lambda k, v: f"[axes]\n{k} = {v}\n", st.sampled_from(["seeds", "domains", "snrs", "scenarios", "models",
                                                                     "voices", "nbest", "x"]),
              st.sampled_from(["[0]", "[0.5]", "[-1]", '["a"]', "[[1, 2]]", "[]", "1", '"s"', "[true]",
                               "[1979-05-27]", "[{a = 1}]", "[[[]]]", "[1e400]"])),
    st.builds(lambda s, k, v: f"[{s}]\n{k} = {v}\n[axes]\nseeds = [0]\n",
              st.sampled_from(["dataset", "eval", "axes", "other"]),
              st.sampled_from(["scenarios", "speakers", "seed", "voices", "snrs", "models", "engine", "domain"]),
              st.sampled_from(["1", "-3", "0.5", '"x"', "[1]", "[]", "true", "{a = 1}", '["flite-slt"]'])),
)


@FAST
@given(toml_text | st.binary(max_size=120).map(lambda b: b.decode("latin-1")))
def test_sweep_toml(text):
    from siftom.bench.sweep import load_config, plan

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.toml"
        p.write_bytes(text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text)

        def load() -> None:
            plan(load_config(p), Path(d) / "out")

        _only_siftom_errors(load)


def _deep(n: int) -> str:
    return "[" * n + "]" * n


answers = st.one_of(
    st.text(max_size=200),
    json_values.map(json.dumps),
    st.integers(1, 3000).map(_deep),
    st.integers(4300, 6000).map(lambda n: '{"n": ' + "7" * n + "}"),
    json_values.map(lambda v: "```json\n" + json.dumps(v) + "\n```"),
)


@FAST
@given(answers, st.sampled_from(["scene_graph", "actions", "goals"]))
def test_vision_model_answers(text, schema):
    from siftom.perception.scene import parse_scene
    from siftom.perception.schemas import check_schema
    from siftom.perception.vlm import parse_answer

    def read() -> None:
        answer = parse_answer(text)
        check_schema(answer, schema)
        if schema == "scene_graph":
            parse_scene(answer)

    _only_siftom_errors(read)


@pytest.mark.parametrize("depth", [10, 100, 1000, 100_000])
def test_deeply_nested_inputs_everywhere(depth):
    from siftom.perception.vlm import parse_answer
    from siftom.world.scenegraph import SceneGraph

    _only_siftom_errors(parse_answer, _deep(depth))
    _only_siftom_errors(SceneGraph.parse, _deep(depth))
