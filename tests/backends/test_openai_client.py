"""The OpenAI-compatible client against a local test server that checks the requests."""

import json

import pytest

from siftom.backends.config import LLMConfig, cache_root, llm_configured
from siftom.backends.openai_compat import EndpointCapabilityError, OpenAIClient
from siftom.errors import BackendUnavailableError, UnknownNameError
from support.fake_openai import Reply, chat_answer, echo_logprobs


def client(server, tmp_path, **kw):
    c = OpenAIClient(base_url=server.url, model="fake", api_key="sk-test", cache_dir=tmp_path,
                     backoff_s=0.0, **kw)
    c._sleep = lambda s: None
    return c


def test_config_reads_the_environment_and_overrides_win(tmp_path):
    env = {"SIFTOM_LLM_BASE_URL": "http://h:1/v1/", "SIFTOM_LLM_MODEL": "m", "SIFTOM_LLM_API_KEY": "sk-secret",
           "SIFTOM_LLM_TIMEOUT": "7.5", "SIFTOM_LLM_MAX_RETRIES": "1", "SIFTOM_CACHE_DIR": str(tmp_path)}
    cfg = LLMConfig.from_env(env)
    assert (cfg.backend, cfg.base_url, cfg.model, cfg.api_key) == ("openai", "http://h:1/v1", "m", "sk-secret")
    assert (cfg.timeout_s, cfg.max_retries, cfg.cache_dir) == (7.5, 1, tmp_path)
    assert LLMConfig.from_env(env, model="other", base_url=None).model == "other"
    assert "sk-secret" not in json.dumps(cfg.to_json()) and cfg.to_json()["api_key_set"] is True
    assert LLMConfig.from_env({}).backend == "llama" and not llm_configured({})
    assert LLMConfig.from_env({"SIFTOM_LLM": "llama", "SIFTOM_LLM_GGUF": "/x.gguf"}).model == "/x.gguf"
    assert llm_configured({"SIFTOM_LLM": "llama"})
    assert LLMConfig.from_env({}).prompt == "sounds"
    assert LLMConfig.from_env({"SIFTOM_LLM_PROMPT": "Plain"}).prompt == "plain"


def test_cache_variable_and_its_deprecated_alias(tmp_path):
    assert cache_root({"SIFTOM_CACHE": str(tmp_path / "old")}) == tmp_path / "old"
    assert cache_root({"SIFTOM_CACHE": "/a", "SIFTOM_CACHE_DIR": str(tmp_path)}) == tmp_path


@pytest.mark.parametrize("env, match", [
    ({"SIFTOM_LLM_BACKEND": "openai"}, "SIFTOM_LLM_BASE_URL"),
    ({"SIFTOM_LLM_BASE_URL": "http://h/v1"}, "SIFTOM_LLM_MODEL"),
    ({"SIFTOM_LLM_BASE_URL": "h:8000", "SIFTOM_LLM_MODEL": "m"}, "http"),
    ({"SIFTOM_LLM_BACKEND": "lama"}, "llama"),
    ({"SIFTOM_LLM_TIMEOUT": "soon"}, "SIFTOM_LLM_TIMEOUT"),
    ({"SIFTOM_LLM_MAX_RETRIES": "-1"}, "max_retries"),
    ({"SIFTOM_LLM_PROMPT": "phonemes"}, "SIFTOM_LLM_PROMPT"),
])
def test_bad_settings_say_how_to_fix_them(env, match):
    with pytest.raises((BackendUnavailableError, UnknownNameError), match=match):
        LLMConfig.from_env(env)


def test_chat_sends_structured_output_and_images_unchanged(fake_openai, tmp_path):
    fake_openai.on("chat/completions", lambda r: Reply.json(chat_answer('{"objects": ["mug"]}')))
    c = client(fake_openai, tmp_path)
    messages = [{"role": "user", "content": [
        {"type": "text", "text": "what is on the desk?"},
        {"type": "image_url", "image_url": {"url": "data:image/png;base64,iVBORw0KGgo="}}]}]
    schema = {"type": "object", "properties": {"objects": {"type": "array", "items": {"type": "string"}}},
              "required": ["objects"]}
    assert c.chat_json(messages, schema, name="scene") == {"objects": ["mug"]}
    req = fake_openai.requests[-1]
    assert req.path == "chat/completions" and req.headers["Authorization"] == "Bearer sk-test"
    assert req.body["messages"] == messages and req.body["model"] == "fake"
    assert req.body["response_format"] == {"type": "json_schema", "json_schema": {
        "name": "scene", "schema": schema, "strict": True}}
    # the same request again comes from the disk cache, also for a new client
    assert client(fake_openai, tmp_path).chat_json(messages, schema, name="scene") == {"objects": ["mug"]}
    assert len(fake_openai.requests) == 1


def test_chat_logprobs_and_samples_are_requested(fake_openai, tmp_path):
    fake_openai.script("chat/completions", Reply.json(chat_answer("A", "B", top_logprobs=[[("A", -0.1)], [("B", -2)]])))
    out = client(fake_openai, tmp_path).chat([{"role": "user", "content": "pick"}], top_logprobs=5, n=2,
                                             temperature=0.7, seed=3, max_tokens=1)
    body = fake_openai.requests[-1].body
    assert body["logprobs"] is True and body["top_logprobs"] == 5 and body["n"] == 2 and body["seed"] == 3
    assert [OpenAIClient.message_text(out, k) for k in (0, 1)] == ["A", "B"]


def test_retries_429_500_malformed_and_timeouts_then_succeeds(fake_openai, tmp_path):
    fake_openai.script("chat/completions", Reply.error(429, "slow down", **{"Retry-After": "0"}),
                       Reply.error(500), Reply.malformed(), Reply.slow(1.0), Reply.json(chat_answer("ok")))
    c = client(fake_openai, tmp_path, timeout_s=0.3, max_retries=4)
    waits = []
    c._sleep = waits.append
    out = c.chat([{"role": "user", "content": "hi"}])
    assert OpenAIClient.message_text(out) == "ok"
    assert len(fake_openai.requests) == 5 and c.requests == 5 and len(waits) == 4


def test_backoff_grows_exponentially(fake_openai, tmp_path):
    fake_openai.on("chat/completions", lambda r: Reply.error(503, "overloaded"))
    c = OpenAIClient(base_url=fake_openai.url, model="fake", cache_dir=False, backoff_s=0.5, max_retries=3)
    waits = []
    c._sleep = waits.append
    with pytest.raises(BackendUnavailableError, match="4 time.*503"):
        c.chat([{"role": "user", "content": "hi"}])
    assert waits == [0.5, 1.0, 2.0]


def test_clear_errors_for_what_an_endpoint_lacks(fake_openai, tmp_path):
    c = client(fake_openai, tmp_path)
    with pytest.raises(EndpointCapabilityError, match="does not exist.*chat path"):
        c.score("x", [("Heard:", " milk\n")])  # no /completions at all
    fake_openai.on("completions", lambda r: Reply.json({"choices": [{"index": 0, "text": "", "logprobs": None}]}))
    with pytest.raises(EndpointCapabilityError, match="echo"):
        c.score("x", [("Heard:", " milk\n")])
    fake_openai.script("chat/completions", Reply.error(400, "response_format json_schema is not supported"))
    with pytest.raises(EndpointCapabilityError, match="response_format"):
        c.chat_json([{"role": "user", "content": "x"}], {"type": "object"})
    fake_openai.script("chat/completions", Reply.json(chat_answer("sure, here it is")))
    with pytest.raises(EndpointCapabilityError, match="not JSON"):
        c.chat_json([{"role": "user", "content": "y"}], {"type": "object"})
    fake_openai.script("chat/completions", Reply.error(401, "bad key"))
    with pytest.raises(BackendUnavailableError, match="SIFTOM_LLM_API_KEY"):
        c.chat([{"role": "user", "content": "z"}])


def test_connection_refused_fails_fast():
    c = OpenAIClient(base_url="http://127.0.0.1:9/v1", model="m", cache_dir=False)
    with pytest.raises(BackendUnavailableError, match="cannot reach.*SIFTOM_LLM_BASE_URL"):
        c.chat([{"role": "user", "content": "hi"}])
    assert c.requests == 1


def test_echo_scoring_sums_only_the_target_tokens(fake_openai, tmp_path):
    fake_openai.on("completions", echo_logprobs(lambda text, off, tok: -0.5 if "milk" in tok else -1.0))
    c = client(fake_openai, tmp_path)
    (v,) = c.score("Intro\n", [("Heard:", " the milk\n")])
    assert v == pytest.approx(-1.0 - 0.5 - 1.0)  # " the", " milk", "\n"
    body = fake_openai.bodies("completions")[0]
    assert body["echo"] is True and body["logprobs"] == 1 and body["max_tokens"] == 0
