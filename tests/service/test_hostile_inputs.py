"""Hostile inputs are refused before any work: a world over a limit (places, objects, classes,
name lengths) is a 4xx naming the limit and the world's value, answered at once, at session
creation and at ``POST /v1/perceive``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from siftom.service.app import create_app
from support.client import local_client

FAST_S = 1.0


def _world(n_places: int = 3, cls: str = "tomato", n_classes: int = 1) -> dict[str, Any]:
    places = [{"name": f"p{i}", "kind": "surface", "room": f"r{i % 7}", "pos": [i % 50, i // 50]}
              for i in range(n_places)]
    classes = [cls] if n_classes == 1 else [f"thing{'x' * (k // 26)}{chr(97 + k % 26)}" for k in range(n_classes)]
    items = [{"name": f"o{k}", "class": c, "at": "p0"} for k, c in enumerate(classes)]
    return {"places": places, "items": items, "target": "p0", "goals": [{"name": "g", "counts": {classes[0]: 1}}]}


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    with local_client(create_app(tmp_path_factory.mktemp("hostile")), raise_server_exceptions=False) as c:
        c.post("/v1/sessions", json={"world": _world()})  # warm: the first request imports the models
        yield c


def _refused(client: TestClient, path: str, body: dict[str, Any], limit: str, value: int) -> None:
    t0 = time.perf_counter()
    r = client.post(path, json=body)
    took = time.perf_counter() - t0
    assert 400 <= r.status_code < 500, r.text[:300]
    assert r.headers["content-type"].startswith("application/problem+json")
    detail = r.json()["detail"]
    assert limit in detail and str(value) in detail, detail
    assert took < FAST_S, f"refused after {took:.2f} s"


def test_a_3000_place_world_is_refused_at_once(client: TestClient) -> None:
    _refused(client, "/v1/sessions", {"world": _world(3000)}, "max_places", 3000)


def test_a_100000_letter_class_name_is_refused_at_once(client: TestClient) -> None:
    world = _world(4, cls="a" * 100_000)
    _refused(client, "/v1/sessions", {"world": world}, "max_class_chars", 100_000)


def test_too_many_classes_and_objects_are_refused(client: TestClient) -> None:
    _refused(client, "/v1/sessions", {"world": _world(4, n_classes=100)}, "max_classes", 100)
    world = _world(4)
    world["items"] = [{"name": f"t{k}", "class": "tomato", "at": "p0"} for k in range(500)]
    _refused(client, "/v1/sessions", {"world": world}, "--max-world-items", 500)


def test_a_huge_scene_graph_is_refused_at_once(client: TestClient) -> None:
    graph = {"nodes": [{"id": k, "class_name": "chair"} for k in range(6000)], "edges": []}
    _refused(client, "/v1/sessions", {"world": graph}, "max_nodes", 6000)


def test_perceive_refuses_a_huge_world_at_once(client: TestClient) -> None:
    frame = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg=="
    _refused(client, "/v1/perceive", {"frames": [frame], "world": _world(3000)}, "max_places", 3000)
    _refused(client, "/v1/perceive", {"frames": [frame], "world": _world(4, cls="b" * 100_000)},
             "max_class_chars", 100_000)


def test_a_world_within_the_limits_is_still_accepted(client: TestClient) -> None:
    r = client.post("/v1/sessions", json={"world": _world(60, n_classes=40)})
    assert r.status_code == 201, r.text[:300]


def test_load_scene_checks_the_bounds_first(tmp_path: Path) -> None:
    import json

    from siftom.world.io import WorldTooLargeError, load_scene

    f = tmp_path / "w.json"
    f.write_text(json.dumps(_world(3000)))
    t0 = time.perf_counter()
    with pytest.raises(WorldTooLargeError, match="max_places"):
        load_scene(f)
    assert time.perf_counter() - t0 < FAST_S
