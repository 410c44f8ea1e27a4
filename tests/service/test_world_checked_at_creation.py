"""A world is checked for what every instruction will need when the session is created: a class
with no spoken name (``mug2``) is a 422 then, naming the class and the fix, not at the first
instruction."""

from __future__ import annotations

import json
from pathlib import Path

from siftom.service.app import create_app
from support.client import local_client

ROOT = Path(__file__).parents[2]
SALAD = (ROOT / "docs" / "examples" / "salad" / "world.json").read_text()


def test_a_class_without_a_spoken_name_is_refused_at_creation(tmp_path: Path) -> None:
    c = local_client(create_app(tmp_path / "data"), raise_server_exceptions=False)
    world = json.loads(SALAD.replace('"tomato"', '"mug2"'))
    r = c.post("/v1/sessions", json={"world": world})
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert "'mug2'" in detail and '"names"' in detail  # the fix: the names people say for it
    assert c.post("/v1/sessions", json={"world": json.loads(SALAD)}).status_code == 201
