"""A world JSON field of the wrong JSON type is refused naming the field and the fix, before
anything reads it: never a Python exception's name ("AttributeError: 'list' object..."), never
a text read letter by letter (``"open": "fridge"`` was read as the places 'f', 'r', ...), never
a list taken as a name (``"name": ["x"]`` became the place "['x']")."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import pytest

from siftom.errors import ObservationError
from siftom.world.io import scene_from_json

ROOT = Path(__file__).resolve().parents[2]
WORLD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
PYTHON = re.compile(r"Error\b|object has no attribute|not iterable|could not convert|\[\'")


def _with(path: str, value: Any) -> dict[str, Any]:
    obj = copy.deepcopy(WORLD)
    *parents, last = path.split(".")
    node: Any = obj
    for key in parents:
        node = node[int(key)] if key.isdigit() else node[key]
    node[int(last) if last.isdigit() else last] = value
    return obj


CASES = [
    ("open", "fridge", "open must be a list", '["fridge"]'),
    ("open", {"fridge": True}, "open must be a list", '["fridge"]'),
    ("open", 3, "open must be a list", '["fridge"]'),
    ("open", [["fridge"]], "open[0] must be a name", '"fridge"'),
    ("items", {"a": 1}, "items must be a list", '"class"'),
    ("items", None, "items must be a list", '"class"'),
    ("items", [["lettuce"]], "items[0] must be an object", '"class"'),
    ("items.0.name", ["x"], "items[0].name must be a name", '"milk_1"'),
    ("items.0.class", 5, "items[0].class must be a name", '"milk"'),
    ("items.0.at", ["counter"], "items[0].at must be a name", '"fridge"'),
    ("doors", "x", "doors must be a list", '"rooms"'),
    ("doors", [[1, 2]], "doors[0] must be an object", '"rooms"'),
    ("doors.0.pos", "here", "doors[0].pos must be [x, y]", "[2, 0]"),
    ("doors.0.rooms", "ab", "doors[0].rooms must be a list of two room names", '["kitchen", "dining"]'),
    ("agents", ["counter"], "agents must be an object", '"human"'),
    ("agents", "counter", "agents must be an object", '"human"'),
    ("agents.human", 1, "agents.human must be a name", '"counter"'),
    ("places.0.name", ["x"], "places[0].name must be a name", '"fridge"'),
    ("places.0.name", 7, "places[0].name must be a name", '"fridge"'),
    ("places.0.room", {}, "places[0].room must be a name", '"kitchen"'),
    ("places.0.closable", "no", "places[0].closable must be true or false", "true"),
    ("places.0.pos", [True, False], "places[0].pos must be [x, y]", "[5, 1]"),
    ("target", ["counter"], "target must be a name", '"table"'),
    ("verb", 3, "verb must be a name", '"deliver"'),
    ("goal_space", ["kitchen-v0"], "goal_space must be a name", '"kitchen-v0"'),
    ("goals.0.name", ["salad"], "goals[0].name must be a name", '"salad"'),
]


@pytest.mark.parametrize(("path", "value", "says", "example"), CASES, ids=[f"{c[0]}={c[1]!r}"[:40] for c in CASES])
def test_a_field_of_the_wrong_type_is_named_with_its_fix(path: str, value: Any, says: str, example: str) -> None:
    with pytest.raises(ObservationError) as exc:
        scene_from_json(_with(path, value))
    msg = str(exc.value)
    assert msg.startswith(says), msg
    assert example in msg and "docs/world.md" in msg, msg
    assert not PYTHON.search(msg), msg


def test_the_service_names_the_field_too(tmp_path: Path) -> None:
    from siftom.service.app import create_app
    from support.client import local_client

    app = create_app(tmp_path / "data")
    try:
        with local_client(app) as client:
            r = client.post("/v1/sessions", json={"world": _with("open", "fridge")})
    finally:
        app.state.runtime.close()
    assert r.status_code == 422, r.text[:300]
    assert "open must be a list" in r.text and "unknown place 'f'" not in r.text


def test_the_example_world_still_loads() -> None:
    assert scene_from_json(copy.deepcopy(WORLD)).world.places
