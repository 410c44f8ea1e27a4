"""Idempotency-Key on every mutating session request, and replies that report their own request."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from siftom.service.app import create_app
from support.client import local_client

ROOT = Path(__file__).parents[2]
SALAD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
SALAD_ACTIONS = [ln for ln in (ROOT / "docs" / "examples" / "salad" / "actions.txt").read_text().splitlines()
                 if ln.strip() and not ln.startswith("#")]


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    return tmp_path / "data"


def _client(folder: Path) -> TestClient:
    return local_client(create_app(folder), raise_server_exceptions=False)


def test_a_retried_append_with_the_same_key_returns_the_first_answer_and_adds_nothing(folder):
    c = _client(folder)
    sid = c.post("/v1/sessions", json={"world": SALAD}).json()["id"]
    first = c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[:1]}, headers={"Idempotency-Key": "a1"})
    assert first.status_code == 200 and "idempotent-replayed" not in first.headers
    again = c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[:1]}, headers={"Idempotency-Key": "a1"})
    assert again.status_code == 200 and again.headers["idempotent-replayed"] == "true"
    assert again.json() == first.json()
    assert c.get(f"/v1/sessions/{sid}").json()["n_actions"] == 1
    # later actions do not change the stored first answer
    c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[1:3]}, headers={"Idempotency-Key": "a2"})
    assert c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[:1]},
                  headers={"Idempotency-Key": "a1"}).json() == first.json()
    assert c.get(f"/v1/sessions/{sid}").json()["n_actions"] == 3
    # the same key with another request is a client bug, not a retry
    r = c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[3:4]}, headers={"Idempotency-Key": "a1"})
    assert r.status_code == 422 and "different request" in r.json()["detail"]
    r = c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[3:4]}, headers={"Idempotency-Key": "a b"})
    assert r.status_code == 422 and "Idempotency-Key" in r.json()["detail"]


def test_keys_survive_a_restart_and_cover_instruction_and_close(folder):
    c = _client(folder)
    sid = c.post("/v1/sessions", json={"world": SALAD}).json()["id"]
    acts = c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[:4]}, headers={"Idempotency-Key": "k1"})
    said = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you get me the potato"},
                  headers={"Idempotency-Key": "k2"})
    assert said.status_code == 200
    c = _client(folder)  # a restarted service on the same folder
    assert c.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS[:4]},
                  headers={"Idempotency-Key": "k1"}).json() == acts.json()
    # an instruction in between does not change what k2 answered
    k3 = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "a bowl please"},
                headers={"Idempotency-Key": "k3"}).json()
    again = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you get me the potato"},
                   headers={"Idempotency-Key": "k2"})
    assert again.json() == said.json() and again.headers["idempotent-replayed"] == "true"
    view = c.get(f"/v1/sessions/{sid}").json()
    assert view["n_actions"] == 4 and view["last_instruction"] == k3
    assert c.delete(f"/v1/sessions/{sid}", headers={"Idempotency-Key": "bye"}).status_code == 204
    assert c.delete(f"/v1/sessions/{sid}", headers={"Idempotency-Key": "bye"}).status_code == 204
    assert c.delete(f"/v1/sessions/{sid}", headers={"Idempotency-Key": "other"}).status_code == 404
    assert c.delete(f"/v1/sessions/{sid}").status_code == 404


def test_concurrent_replies_report_their_own_request(folder):
    from concurrent.futures import ThreadPoolExecutor

    import httpx

    from siftom.service.local_server import serve_in_thread

    places = ["fridge", "counter", "cabinet", "pantry_shelf"]
    with serve_in_thread(create_app(folder)) as url, \
            httpx.Client(base_url=url, timeout=60, limits=httpx.Limits(max_connections=32)) as c:
        sid = c.post("/v1/sessions", json={"world": SALAD}).json()["id"]

        def send(k: int) -> dict:
            r = c.post(f"/v1/sessions/{sid}/actions", json={"actions": [f"walk(human, {places[k % 4]})"]})
            return r.json() if r.status_code == 200 else {}

        with ThreadPoolExecutor(16) as pool:
            replies = [r for r in pool.map(send, range(160)) if r]
        stored = c.get(f"/v1/sessions/{sid}").json()["actions"]
    assert len(replies) > 50
    for r in replies:  # each reply's count and state are those right after its own action
        assert r["added"] == [stored[r["n_actions"] - 1]]
        assert r["state"]["agents"]["human"] == r["added"][0].split(", ")[1].rstrip(")")


def test_words_that_hold_no_instruction_are_not_acted_on(folder):
    c = _client(folder)
    sid = c.post("/v1/sessions", json={"world": SALAD}).json()["id"]
    r = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "what time is it"}).json()
    assert r["evidence"]["no_instruction"] and r["message"] == "no instruction heard"
    assert r["clarification"]["ask"] is False and r["clarification"]["command"] == "none"
    r = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you get me the potato"}).json()
    assert "no_instruction" not in r["evidence"] and r.get("message", "") == ""
