"""siftom perceive against a local OpenAI-compatible server: requests, the chain into infer, the cache."""

from __future__ import annotations

import base64
import json

import pytest

from perception.ideal import SCENARIO, STEPS, handler, images, scene_answer, schema_name
from siftom.cli import main
from siftom.errors import BackendUnavailableError
from siftom.perception import Frame, VisionModel, perceive
from siftom.perception.pipeline import KnownWorld
from siftom.perception.schemas import SCHEMAS
from siftom.scenarios.base import get_scenario


def test_perceive_then_infer_chain(vlm_env, frames, tmp_path, capsys):
    vlm_env.on("chat/completions", handler(frames))
    world, acts = tmp_path / "world.json", tmp_path / "actions.txt"
    rc = main(["perceive", *map(str, frames), "--goal-space", "kitchen-v0", "--out", str(world),
               "--actions-out", str(acts)])
    assert rc == 0, capsys.readouterr().err
    sc = get_scenario(SCENARIO)
    assert acts.read_text().splitlines() == [sc.world.format_action(a) for a in sc.actions]
    w = json.loads(world.read_text())
    assert sorted(it["name"] for it in w["items"]) == sorted(it.name for it in sc.world.items)
    assert w["target"] == "kitchen_counter" and w["verb"] == "fetch"
    names = [g["name"] for g in w["goals"]]
    assert "breakfast_cereal" in names and "cereal_for_two" in names  # library + the new proposal
    assert len(names) == len(sc.goals) + 1 == len(set(names))
    capsys.readouterr()
    rc = main(["infer", "--scene", str(world), "--actions", str(acts), "--transcript", "can you pass me the silver",
               "--json"])
    out = capsys.readouterr().out
    assert rc == 0
    post = json.loads(out)
    assert post["top_command"] == "fetch(cereal)" and post["n_actions"] == 10


def test_requests_carry_the_images_the_schema_and_the_model(vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames))
    res = perceive([Frame.from_path(f) for f in frames], goal_space="kitchen-v0")
    reqs = vlm_env.requests
    assert [schema_name(r) for r in reqs] == ["scene_graph", "actions", "actions", "goals"]
    assert res.requests == 4 and res.cache_hits == 0
    for r in reqs:
        assert r.body["model"] == "fake-vlm"  # SIFTOM_VLM_MODEL wins over SIFTOM_LLM_MODEL
        fmt = r.body["response_format"]
        assert fmt["type"] == "json_schema" and fmt["json_schema"]["schema"] == SCHEMAS[schema_name(r)]
        assert r.body["messages"][0]["role"] == "system"
        url = r.body["messages"][1]["content"][1]["image_url"]["url"]
        assert url.startswith("data:image/png;base64,")
    raw = [f.read_bytes() for f in frames]
    assert [images(r) for r in reqs] == [[raw[0]], [raw[0], raw[1]], [raw[1], raw[2]], [raw[2]]]
    text = reqs[2].body["messages"][1]["content"][0]["text"]
    assert "milk" in text and "kitchen_counter: surface in the kitchen; holds milk" in text  # state after frame 2


def test_cache_answers_a_rerun_without_requests(vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames))
    fr = [Frame.from_path(f) for f in frames]
    first = perceive(fr, goal_space="kitchen-v0")
    n = len(vlm_env.requests)
    again = perceive(fr, goal_space="kitchen-v0")
    assert len(vlm_env.requests) == n and again.cache_hits == 4 and again.requests == 0
    assert again.world == first.world and again.actions == first.actions
    # another picture is another question
    other = Frame.from_bytes(fr[0].data + b"\0", "changed.png")
    with pytest.raises(BackendUnavailableError, match="has not seen this frame"):  # so it was asked
        perceive([other], goal_space="kitchen-v0")
    assert len(vlm_env.requests) == n + 1


def test_a_known_world_skips_the_scene_question(vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames))
    sc = get_scenario(SCENARIO)
    s = sc.to_json()
    world = {"places": s["places"], "items": [{"name": o["name"], "class": o["class"], "at": o["at"]} for o in s["objects"]],
             "agents": s["agents"], "target": "kitchen_counter", "goals": [{"name": "mine", "counts": {"jam": 1}}]}
    res = perceive([Frame.from_path(f) for f in frames], world=KnownWorld.from_json(world), propose_goals=False)
    assert [schema_name(r) for r in vlm_env.requests] == ["actions", "actions"]
    assert len(res.actions) == 10 and res.world["goals"] == [{"name": "mine", "counts": {"jam": 1}}]
    assert res.graph is None


def test_one_frame_gives_a_scene_and_no_actions(vlm_env, frames):
    vlm_env.on("chat/completions", handler(frames[:1], STEPS[:1]))
    res = perceive([Frame.from_path(frames[0])], goal_space="kitchen-v0", propose_goals=False, target="kitchen_counter")
    assert res.actions == () and len(res.world["items"]) == 45
    assert sorted(n.id for n in res.graph.nodes) == sorted(n["id"] for n in scene_answer(0)["nodes"])
    assert len(res.world["goals"]) > 100  # the recipe library, every recipe these objects allow


def test_frames_must_be_images(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("hello")
    with pytest.raises(Exception, match="not a JPEG, PNG"):
        Frame.from_path(bad)
    png = Frame.from_bytes(b"\x89PNG\r\n\x1a\n" + b"x" * 10)
    assert Frame.from_data_url(png.data_url()).data == png.data
    assert Frame.from_data_url(base64.b64encode(png.data).decode()).mime == "image/png"
    with pytest.raises(Exception, match="not base64"):
        Frame.from_data_url("data:image/png;base64,@@@")


def test_no_endpoint_configured_says_what_to_set(monkeypatch, tmp_path):
    for k in ("SIFTOM_LLM_BASE_URL", "SIFTOM_LLM_BACKEND", "SIFTOM_LLM"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("SIFTOM_VLM_MODEL", "m")
    with pytest.raises(BackendUnavailableError, match="SIFTOM_LLM_BASE_URL"):
        VisionModel()



def test_actions_alone_for_a_known_world(vlm_env, frames):
    """What a session with a known world needs: frames -> checked actions and the state after them."""
    from siftom.perception import perceive_actions

    vlm_env.on("chat/completions", handler(frames))
    sc = get_scenario(SCENARIO)
    acts, state = perceive_actions(sc.world, sc.states()[5], [Frame.from_path(f) for f in frames[1:]], first=2)
    assert acts == [sc.world.format_action(a) for a in sc.actions[5:]]  # frames 5 -> 10
    assert state == sc.now


def test_cli_with_a_world_file_and_the_graph_out(vlm_env, frames, tmp_path, capsys, monkeypatch):
    vlm_env.on("chat/completions", handler(frames))
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", "http://127.0.0.1:9/v1")  # the flag wins
    graph = tmp_path / "graph.json"
    assert main(["perceive", str(frames[0]), "--llm-base-url", vlm_env.url, "--goal-space", "kitchen-v0", "--out", str(tmp_path / "w0.json"),
                 "--actions-out", str(tmp_path / "a0.txt"), "--graph-out", str(graph)]) == 0
    assert len(json.loads(graph.read_text())["nodes"]) == len(scene_answer(0)["nodes"])
    n = len(vlm_env.requests)
    capsys.readouterr()
    # the world just written is the known world of the next call: only the actions are asked
    assert main(["perceive", *map(str, frames), "--world", str(tmp_path / "w0.json"), "--no-goals",
                 "--llm-base-url", vlm_env.url,
                 "--out", str(tmp_path / "w.json"), "--actions-out", str(tmp_path / "a.txt"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [schema_name(r) for r in vlm_env.requests[n:]] == ["actions", "actions"]
    assert out["world"]["goals"] == json.loads((tmp_path / "w0.json").read_text())["goals"]
    assert len(out["actions"]) == 10


def test_a_cached_answer_that_no_longer_checks_is_asked_again(vlm_env, frames, tmp_path):
    vlm_env.on("chat/completions", handler(frames))
    fr = [Frame.from_path(f) for f in frames]
    perceive(fr, goal_space="kitchen-v0")
    cached = list((tmp_path / "cache" / "perception").glob("*.json"))
    assert len(cached) == 4
    for path in cached:
        if "actions" in json.loads(path.read_text()):
            path.write_text(json.dumps({"actions": ["fly(human, moon)"]}))
    again = perceive(fr, goal_space="kitchen-v0")
    assert again.requests == 2 and again.cache_hits == 2 and len(again.actions) == 10
