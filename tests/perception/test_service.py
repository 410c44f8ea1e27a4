"""POST /v1/perceive against the local fake vision model."""

from __future__ import annotations

import base64

import pytest

pytest.importorskip("fastapi", reason="needs the serve extra")
pytest.importorskip("httpx", reason="needs httpx (the dev extra)")

from perception.ideal import handler  # noqa: E402
from siftom.service.app import create_app  # noqa: E402
from support.client import local_client  # noqa: E402
from support.fake_openai import Reply  # noqa: E402


@pytest.fixture()
def client(tmp_path):
    with local_client(create_app(tmp_path / "serve"), raise_server_exceptions=False) as c:
        yield c


def data_urls(frames):
    return ["data:image/png;base64," + base64.b64encode(f.read_bytes()).decode() for f in frames]


def test_perceive_then_infer_over_http(client, vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames))
    r = client.post("/v1/perceive", json={"frames": data_urls(frames), "goal_space": "kitchen-v0"})
    assert r.status_code == 200, r.text
    body = r.json()
    assert len(body["actions"]) == 10 and body["num_objects"] == 45 and body["requests"] == 4
    assert body["world"]["target"] == "kitchen_counter"
    # the same world and actions feed the library's inference unchanged
    from helpers import model_for
    from siftom.api import make_instruction
    from siftom.inference.model import Observation
    from siftom.world.io import scene_from_json

    scene = scene_from_json(body["world"])
    acts, s = [], scene.start
    from siftom.world.model import apply

    for text in body["actions"]:
        acts.append(scene.world.parse_action(text, s))
        s = apply(s, acts[-1])
    post = model_for().infer(Observation(scene.world, scene.start, tuple(acts), scene.goals, scene.verb,
                                         make_instruction("can you pass me the silver")))
    assert post.command == "fetch(cereal)"


@pytest.mark.parametrize("payload, status, words", [
    ({"frames": ["aGVsbG8="]}, 422, "not a JPEG, PNG"),
    ({"frames": ["data:image/png;base64,@@"]}, 422, "not base64"),
    ({"frames": []}, 422, "frames"),
    ({"frames": ["aGVsbG8="], "goal_space": "garden-v0"}, 422, "goal_space"),
])
def test_bad_input_is_a_422(client, payload, status, words):
    r = client.post("/v1/perceive", json=payload)
    assert r.status_code == status and words in r.text
    assert r.headers["content-type"].startswith("application/problem+json")


def test_a_bad_world_is_a_422_before_the_model_is_asked(client, vlm_env, frames):
    r = client.post("/v1/perceive", json={"frames": data_urls(frames[:1]), "world": {"places": []}})
    assert r.status_code == 422 and "no movable objects" in r.text and vlm_env.requests == []


def test_model_failures_are_502_and_no_model_is_501(client, vlm_env, frames, monkeypatch):
    vlm_env.script("chat/completions", Reply.error(500, "model crashed"))
    r = client.post("/v1/perceive", json={"frames": data_urls(frames[:1])})
    assert r.status_code == 502 and "HTTP 500" in r.json()["detail"]
    monkeypatch.delenv("SIFTOM_LLM_BASE_URL")
    r = client.post("/v1/perceive", json={"frames": data_urls(frames[:1])})
    assert r.status_code == 501 and "SIFTOM_LLM_BASE_URL" in r.json()["detail"]


def test_a_session_takes_frames_instead_of_actions(client, vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames))
    r = client.post("/v1/perceive", json={"frames": data_urls(frames[:1]), "goal_space": "kitchen-v0",
                                          "target": "kitchen_counter", "propose_goals": False})
    assert r.status_code == 200, r.text
    world = r.json()["world"]
    r = client.post("/v1/sessions", json={"world": world, "goal_space": "kitchen-v0"})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    r = client.post(f"/v1/sessions/{sid}/frames", json={"frames": data_urls(frames)})
    assert r.status_code == 200, r.text
    assert len(r.json()["added"]) == 10 and r.json()["n_actions"] == 10
    r = client.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you pass me the silver"})
    assert r.status_code == 200, r.text
    assert r.json()["top_command"] == "fetch(cereal)"
    # the same frames again: the milk is no longer where the first frame shows it -> 422, nothing added
    r = client.post(f"/v1/sessions/{sid}/frames", json={"frames": data_urls(frames)})
    assert r.status_code in (422, 502), r.text
    assert client.get(f"/v1/sessions/{sid}").json()["n_actions"] == 10


def test_session_frames_need_a_session_and_two_frames(client, vlm_env, frames):
    r = client.post("/v1/sessions/s0000000000000000/frames", json={"frames": data_urls(frames[:2])})
    assert r.status_code in (404, 422)
    r = client.post("/v1/sessions/s0000000000000000/frames", json={"frames": data_urls(frames[:1])})
    assert r.status_code == 422
    assert vlm_env.requests == []
