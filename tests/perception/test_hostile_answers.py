"""A vision model's answer, however odd, is a clear error; the server's --llm-* flags reach perception."""

from __future__ import annotations

import base64

import pytest

from perception.ideal import handler
from siftom.cli import main
from siftom.errors import PerceptionError
from siftom.perception.vlm import parse_answer
from support.fake_openai import Reply, chat_answer

DEEP = "[" * 200_000 + "]" * 200_000
HUGE_INT = '{"nodes": [], "edges": [], "n": ' + "9" * 5000 + "}"
NESTED = '{"a": ' * 100 + "1" + "}" * 100


@pytest.mark.parametrize("text, words", [(DEEP, "too deeply"), (HUGE_INT, "too many digits"),
                                         (NESTED, "more than 64 levels")])
def test_parse_answer_turns_every_json_failure_into_a_perception_error(text, words):
    with pytest.raises(PerceptionError, match=words):
        parse_answer(text)


def test_the_cli_reports_a_deep_answer_without_a_traceback(vlm_env, frames, tmp_path, capsys):
    vlm_env.on("chat/completions", lambda req: Reply.json(chat_answer(DEEP)))
    rc = main(["perceive", str(frames[0]), "--goal-space", "kitchen-v0", "--out", str(tmp_path / "w.json"),
               "--actions-out", str(tmp_path / "a.txt")])
    err = capsys.readouterr().err
    assert rc == 2 and "too deeply" in err and "Traceback" not in err


def _urls(frames):
    return ["data:image/png;base64," + base64.b64encode(f.read_bytes()).decode() for f in frames]


def test_over_http_a_hostile_answer_is_a_problem_and_the_connection_survives(vlm_env, frames, tmp_path):
    import httpx

    from siftom.service.app import create_app
    from siftom.service.local_server import serve_in_thread

    vlm_env.on("chat/completions", lambda req: Reply.json(chat_answer(HUGE_INT)))
    with serve_in_thread(create_app(tmp_path / "serve")) as url, httpx.Client(base_url=url, timeout=60) as c:
        r = c.post("/v1/perceive", json={"frames": _urls(frames[:1]), "goal_space": "kitchen-v0"})
        assert r.status_code == 502 and "too many digits" in r.json()["detail"]
        assert r.headers["content-type"].startswith("application/problem+json")
        assert c.get("/healthz").status_code == 200  # the same keep-alive connection


def test_serve_flags_reach_the_vision_path(fake_openai, frames, tmp_path, monkeypatch):
    from siftom.backends.config import LLMConfig
    from siftom.service.app import create_app
    from siftom.service.runtime import ServiceSettings
    from support.client import local_client

    for k in ("SIFTOM_LLM_BASE_URL", "SIFTOM_LLM_MODEL", "SIFTOM_VLM_MODEL", "SIFTOM_LLM_BACKEND"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("SIFTOM_CACHE_DIR", str(tmp_path / "cache"))
    fake_openai.on("chat/completions", handler(frames))
    llm = LLMConfig(backend="openai", base_url=fake_openai.url, model="fake-vlm", max_retries=0)
    c = local_client(create_app(tmp_path / "serve", ServiceSettings(llm=llm)), raise_server_exceptions=False)
    r = c.post("/v1/perceive", json={"frames": _urls(frames[:1]), "goal_space": "kitchen-v0"})
    assert r.status_code == 200, r.text
    assert fake_openai.requests and fake_openai.requests[0].body["model"] == "fake-vlm"


def test_hints_name_options_that_exist(capsys):
    import inspect

    from siftom.speech.audio import as_audio, load_audio

    assert main(["perceive", "--help"]) == 0
    assert "--max-tokens" in capsys.readouterr().out
    assert "max_seconds" in inspect.signature(load_audio).parameters
    assert "max_seconds" in inspect.signature(as_audio).parameters


def test_session_frames_take_an_idempotency_key(vlm_env, frames, tmp_path):
    from siftom.service.app import create_app
    from support.client import local_client

    vlm_env.on("chat/completions", handler(frames))
    c = local_client(create_app(tmp_path / "serve"), raise_server_exceptions=False)
    r = c.post("/v1/perceive", json={"frames": _urls(frames[:1]), "goal_space": "kitchen-v0",
                                     "target": "kitchen_counter", "propose_goals": False})
    sid = c.post("/v1/sessions", json={"world": r.json()["world"]}).json()["id"]
    first = c.post(f"/v1/sessions/{sid}/frames", json={"frames": _urls(frames)}, headers={"Idempotency-Key": "f1"})
    assert first.status_code == 200, first.text
    asked = len(vlm_env.requests)
    again = c.post(f"/v1/sessions/{sid}/frames", json={"frames": _urls(frames)}, headers={"Idempotency-Key": "f1"})
    assert again.json() == first.json() and again.headers["idempotent-replayed"] == "true"
    assert len(vlm_env.requests) == asked  # the model is not asked again
    assert c.get(f"/v1/sessions/{sid}").json()["n_actions"] == first.json()["n_actions"] == 10
