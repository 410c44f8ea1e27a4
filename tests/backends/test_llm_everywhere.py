"""One LLM configuration everywhere: the CLI, infer_scenario and the service all query the
configured OpenAI-compatible endpoint (a local test server that records the requests)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from siftom.api import infer_scenario, make_instruction
from support.fake_openai import Reply, chat_answer, echo_logprobs

HEARD = "can you pass me the silver"


def likes_cereal(text: str, offset: int, token: str) -> float:
    """An LM that finds the heard words likely after the cereal command, unlikely otherwise."""
    command = text.rsplit("Command:", 1)[1].split("\n", 1)[0]
    heard_at = text.rfind("Heard:") + len("Heard:")
    if offset < heard_at:
        return -1.0
    return -0.1 if "cereal" in command else -2.0


@pytest.fixture()
def endpoint(fake_openai, tmp_path, monkeypatch):
    fake_openai.on("completions", echo_logprobs(likes_cereal))
    for var in ("SIFTOM_LLM", "SIFTOM_LLM_BACKEND", "SIFTOM_LLM_API_KEY", "SIFTOM_LLM_GGUF"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", fake_openai.url)
    monkeypatch.setenv("SIFTOM_LLM_MODEL", "fake-model")
    monkeypatch.setenv("SIFTOM_CACHE_DIR", str(tmp_path / "cache"))
    return fake_openai


def _check_scoring_requests(server, heard: str = HEARD) -> None:
    bodies = server.bodies("completions")
    assert bodies, "the endpoint was never asked"
    prompts = [p for b in bodies for p in b["prompt"]]
    assert all(b["model"] == "fake-model" and b["echo"] is True and b["max_tokens"] == 0 for b in bodies)
    last = re.compile(r"Command: pass\(robot, human, cereal\)( \[sounds: [A-Z /]+\])?\nHeard: "
                      + re.escape(heard) + r"( \[sounds: [A-Z /]+\])?\n$")
    assert any(last.search(p) for p in prompts)
    assert len({re.findall(r"Command: (.*)\n", p)[-1] for p in prompts}) == 42  # every kitchen item


def test_siftom_infer_reads_the_environment(endpoint):
    from click.testing import CliRunner

    from siftom.cli import root

    res = CliRunner().invoke(root, ["infer", "--scenario", "kitchen-cereal-v0", "--transcript", HEARD,
                                    "--likelihood", "llm", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["command"] == "fetch(cereal)"
    _check_scoring_requests(endpoint)


@pytest.mark.slow
def test_siftom_infer_uses_the_endpoint_from_the_environment(endpoint):
    """The installed command in a fresh process, configured by the environment alone."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")}
    out = subprocess.run([sys.executable, "-m", "siftom.cli", "infer", "--scenario", "kitchen-cereal-v0",
                          "--transcript", HEARD, "--likelihood", "llm", "--json"],
                         capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    post = json.loads(out.stdout)
    assert post["command"] == "fetch(cereal)" and post["likelihood"] == "llm"
    _check_scoring_requests(endpoint)


def test_siftom_infer_flags_override_the_environment(fake_openai, tmp_path, monkeypatch):
    from click.testing import CliRunner

    from siftom.cli import root

    fake_openai.on("completions", echo_logprobs(likes_cereal))
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", "http://127.0.0.1:9/v1")  # wrong: the flag wins
    monkeypatch.setenv("SIFTOM_LLM_MODEL", "other")
    monkeypatch.setenv("SIFTOM_CACHE_DIR", str(tmp_path))
    res = CliRunner().invoke(root, ["infer", "--scenario", "kitchen-cereal-v0", "--transcript", "pass me the mug",
                                    "--likelihood", "llm", "--llm-base-url", fake_openai.url,
                                    "--llm-model", "fake-model", "--json"])
    assert res.exit_code == 0, res.output
    _check_scoring_requests(fake_openai, "pass me the mug")


def test_infer_scenario_takes_a_name_or_an_object(endpoint):
    post = infer_scenario("kitchen-cereal-v0", make_instruction(HEARD), likelihood="llm")
    assert post.command == "fetch(cereal)" and post.likelihood == "llm"
    _check_scoring_requests(endpoint)

    class Sugar:  # any object with name + log_prob is a likelihood
        name = "mine"

        def log_prob(self, instruction, commands):
            return np.array([0.0 if c.obj_class == "sugar" else -50.0 for c in commands])

    post = infer_scenario("kitchen-cereal-v0", make_instruction("can you bring me anything"), likelihood=Sugar())
    assert post.likelihood == "mine" and post.command == "fetch(sugar)"
    with pytest.raises(Exception, match="log_prob"):
        infer_scenario("kitchen-cereal-v0", make_instruction("x"), likelihood=42)


def test_the_service_offers_llm_for_a_configured_endpoint(endpoint, tmp_path):
    pytest.importorskip("fastapi")
    from siftom.service.app import create_app
    from siftom.service.runtime import ServiceSettings
    from support.client import local_client

    os.environ["SIFTOM_LLM_API_KEY"] = "sk-do-not-show"
    try:
        app = create_app(tmp_path / "serve", ServiceSettings())
    finally:
        del os.environ["SIFTOM_LLM_API_KEY"]
    with local_client(app) as client:
        health = client.get("/healthz").json()
        assert "llm" in health["likelihoods"]
        assert health["llm"]["base_url"] == endpoint.url and health["llm"]["model"] == "fake-model"
        assert health["llm"]["api_key_set"] is True and "sk-do-not-show" not in json.dumps(health)
        r = client.post("/v1/infer", json={"scenario": "kitchen-cereal-v0", "transcript": HEARD,
                                           "likelihood": "llm"})
        assert r.status_code == 200, r.text
        assert r.json()["command"] == "fetch(cereal)"
    _check_scoring_requests(endpoint)
    assert endpoint.requests[0].headers["Authorization"] == "Bearer sk-do-not-show"


def test_an_invalid_environment_is_reported_by_healthz_not_a_crash(monkeypatch, tmp_path):
    pytest.importorskip("fastapi")
    from siftom.service.runtime import Runtime, ServiceSettings

    monkeypatch.setenv("SIFTOM_LLM_BACKEND", "openai")
    monkeypatch.delenv("SIFTOM_LLM_BASE_URL", raising=False)
    settings = ServiceSettings()
    assert "llm" not in settings.likelihoods
    status = Runtime(settings, tmp_path).llm_status()
    assert status.offered is False and "SIFTOM_LLM_BASE_URL" in (status.error or "")


# ------------------------------------------------------------------ chat path of the baselines

def _options(messages) -> dict[str, str]:
    return dict(re.findall(r"^(\d+)\. (.*)$", messages[-1]["content"], flags=re.M))


def test_baselines_fall_back_to_chat_multiple_choice_with_top_logprobs(fake_openai, tmp_path):
    from siftom.backends.openai_compat import OpenAIClient
    from siftom.bench import llm_baselines as lb
    from siftom.scenarios.base import get_scenario

    def answer(req):
        opts = _options(req.body["messages"])
        k = next(n for n, c in opts.items() if c.endswith("cereal)"))
        other = next(n for n, c in opts.items() if c.endswith("sugar)"))
        return Reply.json(chat_answer(k, top_logprobs=[[(k, -0.2), (other, -1.8), ("The", -3.0)]]))

    fake_openai.on("chat/completions", answer)  # and no /completions: a chat-only service
    client = OpenAIClient(base_url=fake_openai.url, model="fake", cache_dir=tmp_path)
    ch = lb.LLMChooser(client, with_context=True)
    sc = get_scenario("kitchen-cereal-v0")
    cmd, p = ch.choose(sc, HEARD, lb.command_space(sc))
    assert cmd == "fetch(cereal)" and p == pytest.approx(1 / (1 + np.exp(-1.6)))
    assert ch.used == {"chat-logprobs": 1}
    body = fake_openai.bodies("chat/completions")[0]
    assert body["logprobs"] is True and body["top_logprobs"] == 20
    assert "grab(human, milk, fridge)" in body["messages"][-1]["content"]  # ablated SIFToM sees the scene
    assert len(_options(body["messages"])) == 42


def test_baselines_vote_by_samples_when_chat_has_no_logprobs(fake_openai, tmp_path):
    from siftom.backends.openai_compat import OpenAIClient
    from siftom.bench import llm_baselines as lb
    from siftom.scenarios.base import get_scenario

    def answer(req):
        opts = _options(req.body["messages"])
        cereal = next(n for n, c in opts.items() if c.endswith("cereal)"))
        sugar = next(n for n, c in opts.items() if c.endswith("sugar)"))
        if req.body["temperature"] == 0:  # the greedy question: answered without log-probs
            return Reply.json(chat_answer(cereal))
        # an endpoint that ignores n: one sample per request, varying with the seed
        return Reply.json(chat_answer(sugar if req.body["seed"] % 4 == 3 else f"Option {cereal}"))

    fake_openai.on("chat/completions", answer)
    client = OpenAIClient(base_url=fake_openai.url, model="fake", cache_dir=tmp_path)
    ch = lb.LLMChooser(client, with_context=False, votes=8, seed=0)
    sc = get_scenario("kitchen-cereal-v0")
    cmd, p = ch.choose(sc, HEARD, lb.command_space(sc))
    assert cmd == "fetch(cereal)" and p == pytest.approx(6 / 8)
    assert ch.used == {"chat-votes": 1}
    sampled = [b for b in fake_openai.bodies("chat/completions") if b["temperature"] > 0]
    assert [b["seed"] for b in sampled] == list(range(8)) and all(b["temperature"] == 1.0 for b in sampled)
