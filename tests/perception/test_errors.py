"""Every way a model or its server can fail gives a clear error; a bad answer is retried once."""

from __future__ import annotations

import json

import pytest

from perception.ideal import GOALS, handler, scene_answer
from siftom.cli import main
from siftom.errors import BackendUnavailableError, PerceptionError
from siftom.perception import Frame, perceive
from support.fake_openai import Reply, chat_answer


def answer(obj) -> Reply:
    return Reply.json(chat_answer(obj if isinstance(obj, str) else json.dumps(obj)))


def bad_edge() -> dict:
    g = scene_answer(0)
    g["edges"].append({"from_id": 1000, "relation_type": "ON", "to_id": 777})
    return g


def bad_id() -> dict:
    g = scene_answer(0)
    g["nodes"][0]["id"] = "kitchen"
    return g


def held_milk() -> dict:
    g = scene_answer(0)
    milk = next(n["id"] for n in g["nodes"] if n["class_name"] == "milk")
    g["edges"] = [e for e in g["edges"] if e["from_id"] != milk]
    g["edges"].append({"from_id": 9000, "relation_type": "HOLDS_RH", "to_id": milk})
    return g


BAD_GOALS = {"target": "kitchen_counter", "goals": [{"name": "toast", "counts": [{"class": "toaster", "count": 1}]}]}

# (what goes wrong, overrides of the scripted model by question, expected words in the message)
CASES = {
    "bad-json": ({"scene_graph": "Sure! Here is the scene graph you asked for."}, "the answer is not JSON"),
    "schema": ({"scene_graph": bad_id()}, "schema violation at nodes[0].id: 'kitchen' is not of type 'integer'"),
    "unknown-node-id": ({"scene_graph": bad_edge()}, "refers to node 777, which does not exist"),
    "held-in-first-frame": ({"scene_graph": held_milk()}, "object milk.1025 is held in the first frame"),
    "unknown-object": ({"actions": {"actions": ["walk(human, fridge)", "grab(human, spoon_9, fridge)"]}},
                       "action 2 'grab(human, spoon_9, fridge)': unknown object 'spoon_9'"),
    "illegal-action": ({"actions": {"actions": ["walk(human, fridge)", "grab(human, milk, fridge)"]}},
                       "action 2 'grab(human, milk, fridge)' is impossible"),
    "robot-action": ({"actions": {"actions": ["walk(robot, fridge)"]}}, "report only the person's actions"),
    "goals": ({"goals": BAD_GOALS}, "invalid goals: goals[0] (toast): unknown object class 'toaster'"),
}


def _as_reply(v):
    return v if isinstance(v, str) else json.dumps(v)


@pytest.mark.parametrize("case", list(CASES))
def test_a_rejected_answer_is_retried_once_then_reported(case, vlm_env, frames, tmp_path, capsys):
    overrides, words = CASES[case]
    vlm_env.on("chat/completions", handler(frames))
    stage, bad = next(iter(overrides.items()))
    # the scripted model gives the same wrong answer twice for that question
    base = handler(frames)

    def wrong(req):
        if req.body["response_format"]["json_schema"]["name"] == stage:
            return answer(bad)
        return base(req)

    vlm_env.on("chat/completions", wrong)
    rc = main(["perceive", *map(str, frames), "--goal-space", "kitchen-v0", "--out", str(tmp_path / "w.json"),
               "--actions-out", str(tmp_path / "a.txt")])
    err = capsys.readouterr().err
    assert rc == 2
    assert "rejected twice" in err and words in err, err
    assert not (tmp_path / "w.json").exists()  # nothing half-written
    retry = [r for r in vlm_env.requests if r.body["response_format"]["json_schema"]["name"] == stage][-1]
    msgs = retry.body["messages"]
    assert msgs[-2] == {"role": "assistant", "content": _as_reply(bad)}  # the model sees its answer ...
    assert words.split(":")[0] in msgs[-1]["content"]  # ... and why it was rejected


def test_a_corrected_answer_is_accepted(vlm_env, frames):
    vlm_env.script("chat/completions", answer("```json\n{not quite json\n```"))
    vlm_env.on("chat/completions", handler(frames))
    res = perceive([Frame.from_path(f) for f in frames], goal_space="kitchen-v0")
    assert len(res.actions) == 10 and res.requests == 5  # one retry
    assert "the answer is not JSON" in vlm_env.requests[1].body["messages"][-1]["content"]


def test_a_fenced_json_answer_is_read(vlm_env, frames):
    vlm_env.script("chat/completions", answer("```json\n" + json.dumps(scene_answer(0)) + "\n```"))
    vlm_env.on("chat/completions", handler(frames))
    res = perceive([Frame.from_path(f) for f in frames], goal_space="kitchen-v0")
    assert res.requests == 4


@pytest.mark.parametrize("reply, words", [
    (Reply.error(429, "rate limited"), "HTTP 429"),
    (Reply.error(500, "model crashed"), "HTTP 500"),
    (Reply.slow(1.5), "timed out after 0.3 s"),
])
def test_server_failures_name_the_stage_and_the_cause(reply, words, vlm_env, frames, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_TIMEOUT", "0.3")
    vlm_env.script("chat/completions", reply)
    vlm_env.on("chat/completions", handler(frames))
    rc = main(["perceive", str(frames[0]), "--goal-space", "kitchen-v0", "--out", str(tmp_path / "w.json"),
               "--actions-out", str(tmp_path / "a.txt")])
    err = capsys.readouterr().err
    assert rc == 2 and "scene (frame 1)" in err and words in err, err


def test_server_failures_are_retried_with_backoff(vlm_env, frames, monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_MAX_RETRIES", "2")
    vlm_env.script("chat/completions", Reply.error(429, "slow down", **{"Retry-After": "0"}), Reply.error(500))
    vlm_env.on("chat/completions", handler(frames))
    from siftom.backends.config import LLMConfig
    from siftom.backends.openai_compat import OpenAIClient
    from siftom.perception import VisionModel

    client = OpenAIClient(LLMConfig.from_env(backend="openai", model="fake-vlm"), use_cache=False, backoff_s=0.01)
    res = perceive([Frame.from_path(f) for f in frames], goal_space="kitchen-v0", model=VisionModel(client))
    assert len(res.actions) == 10 and len(vlm_env.requests) == 6 and res.requests == 4


def test_a_truncated_answer_says_to_raise_max_tokens(vlm_env, frames):
    cut = chat_answer('{"nodes": [')
    cut["choices"][0]["finish_reason"] = "length"
    vlm_env.script("chat/completions", Reply.json(cut))
    with pytest.raises(PerceptionError, match="cut off at 8192 tokens"):
        perceive([Frame.from_path(frames[0])], goal_space="kitchen-v0")


def test_not_a_chat_answer(vlm_env, frames):
    vlm_env.script("chat/completions", Reply.json({"choices": []}))
    with pytest.raises(BackendUnavailableError, match="answered without choices"):
        perceive([Frame.from_path(frames[0])], goal_space="kitchen-v0")


def test_goals_must_fit_the_world(vlm_env, frames):
    too_many = {"target": "kitchen_counter", "goals": [{"name": "bowls", "counts": [{"class": "bowl", "count": 3}]}]}
    vlm_env.on("chat/completions", handler(frames, overrides={"goals": too_many}))
    with pytest.raises(PerceptionError, match="needs 3 bowl but the scene has 2"):
        perceive([Frame.from_path(frames[0])])
    vlm_env.on("chat/completions", handler(frames, overrides={"goals": {**GOALS, "target": "dining_table"}}))
    with pytest.raises(PerceptionError, match="unknown place 'dining_table'"):
        perceive([Frame.from_path(frames[0])])
