"""Idempotency-Key on the session-creating and rating POSTs: a retry returns the first answer
and creates nothing new (as on the instruction endpoints)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from siftom.service.app import create_app
from support.client import local_client

ROOT = Path(__file__).parents[2]
SALAD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    return tmp_path / "data"


def _client(folder: Path) -> TestClient:
    return local_client(create_app(folder), raise_server_exceptions=False)


def _count(folder: Path) -> int:
    import sqlite3

    with sqlite3.connect(folder / "sessions.sqlite3") as db:
        return int(db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0])


def test_a_retried_session_create_returns_the_first_session_and_creates_none(folder: Path) -> None:
    c = _client(folder)
    first = c.post("/v1/sessions", json={"world": SALAD}, headers={"Idempotency-Key": "c1"})
    assert first.status_code == 201 and "idempotent-replayed" not in first.headers
    again = c.post("/v1/sessions", json={"world": SALAD}, headers={"Idempotency-Key": "c1"})
    assert again.status_code == 201 and again.headers["idempotent-replayed"] == "true"
    assert again.json() == first.json() and again.headers["location"] == first.headers["location"]
    assert _count(folder) == 1
    # across a restart too
    c = _client(folder)
    assert c.post("/v1/sessions", json={"world": SALAD}, headers={"Idempotency-Key": "c1"}).json()["id"] == \
        first.json()["id"]
    assert _count(folder) == 1
    # the same key with another world is a client bug; without a key each POST is a new session
    other = {**SALAD, "target": SALAD.get("target")}
    r = c.post("/v1/sessions", json={"world": other, "mode": "speech-only"}, headers={"Idempotency-Key": "c1"})
    assert r.status_code == 422 and "different request" in r.json()["detail"]
    assert c.post("/v1/sessions", json={"world": SALAD}).json()["id"] != first.json()["id"]
    assert _count(folder) == 2


def test_a_retried_session_from_scenario_creates_none(folder: Path) -> None:
    c = _client(folder)
    body = {"scenario": "kitchen-cereal-v0", "n_actions": 2}
    first = c.post("/v1/sessions/from-scenario", json=body, headers={"Idempotency-Key": "s1"})
    assert first.status_code == 201
    again = c.post("/v1/sessions/from-scenario", json=body, headers={"Idempotency-Key": "s1"})
    assert again.status_code == 201 and again.headers["idempotent-replayed"] == "true"
    assert again.json() == first.json() and again.json()["n_actions"] == 2
    assert _count(folder) == 1
    r = c.post("/v1/sessions/from-scenario", json={**body, "n_actions": 3}, headers={"Idempotency-Key": "s1"})
    assert r.status_code == 422


def test_a_retried_rating_is_stored_once(folder: Path) -> None:
    c = _client(folder)
    sid = c.post("/v1/sessions", json={"world": SALAD}).json()["id"]
    first = c.post(f"/v1/sessions/{sid}/rating", json={"scores": [5, 6, 7]}, headers={"Idempotency-Key": "r1"})
    assert first.status_code == 201 and "idempotent-replayed" not in first.headers
    again = c.post(f"/v1/sessions/{sid}/rating", json={"scores": [5, 6, 7]}, headers={"Idempotency-Key": "r1"})
    assert again.status_code == 201 and again.headers["idempotent-replayed"] == "true"
    assert again.json() == first.json()
    lines = (folder / "ratings.jsonl").read_text().splitlines()
    assert len(lines) == 1
    r = c.post(f"/v1/sessions/{sid}/rating", json={"scores": [1, 1, 1]}, headers={"Idempotency-Key": "r1"})
    assert r.status_code == 422
    assert c.post(f"/v1/sessions/{sid}/rating", json={"scores": [5, 6, 7]}).status_code == 201
    assert len((folder / "ratings.jsonl").read_text().splitlines()) == 2
