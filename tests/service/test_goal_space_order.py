"""docs/service.md: a session's goals are the request's ``goals``, else the world's own, else ``goal_space``."""

from __future__ import annotations

import json
from pathlib import Path

from siftom.service.app import create_app
from support.client import local_client

ROOT = Path(__file__).parents[2]
SALAD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
SALAD_ACTIONS = [ln for ln in (ROOT / "docs" / "examples" / "salad" / "actions.txt").read_text().splitlines()
                 if ln.strip() and not ln.startswith("#")]
GRAPH = json.loads((ROOT / "data" / "virtualhome" / "apartment_graph.json").read_text())


def test_a_request_goal_space_does_not_replace_the_worlds_own_goals(tmp_path):
    c = local_client(create_app(tmp_path), raise_server_exceptions=False)
    r = c.post("/v1/sessions", json={"world": SALAD, "goal_space": "kitchen-v0"})
    assert r.status_code == 201, r.text
    view = r.json()
    assert view["num_goals"] == 5
    assert any("goal_space 'kitchen-v0' was ignored" in w for w in view["warnings"])
    sid = view["id"]
    c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS})
    answer = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you get me the potato"}).json()
    assert answer["command"] == "fetch(tomato)"
    # without the world's goals, goal_space chooses the library, and nothing is said
    own = {k: v for k, v in SALAD.items() if k != "goals"}
    r = c.post("/v1/sessions", json={"world": own, "goal_space": "kitchen-v0"})
    assert r.status_code == 201 and not any("ignored" in w for w in r.json()["warnings"])


def test_graph_worlds_follow_the_same_order(tmp_path):
    c = local_client(create_app(tmp_path), raise_server_exceptions=False)
    goals = [{"name": "a fork", "counts": {"fork": 1}}]
    r = c.post("/v1/sessions", json={"world": {**GRAPH, "goals": goals}, "goal_space": "kitchen-v0"})
    assert r.status_code == 201, r.text
    assert r.json()["num_goals"] == 1
    assert any("goal_space 'kitchen-v0' was ignored" in w for w in r.json()["warnings"])
    r = c.post("/v1/sessions", json={"world": GRAPH, "goal_space": "kitchen-v0"})  # no goals of its own
    assert r.status_code == 201 and r.json()["verb"] == "fetch"
