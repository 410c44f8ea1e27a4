"""The HTTP API: happy paths, client mistakes as 4xx problem details, limits, path safety."""

from __future__ import annotations

import io
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import soundfile as sf

import siftom
from siftom.inference.model import MODES
from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread
from siftom.service.runtime import ServiceSettings
from siftom.service.schemas import Mode
from support.client import local_client

KITCHEN = "kitchen-cereal-v0"


def problem(r, status: int) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["status"] == status and body["type"].startswith("urn:siftom:problem:") and body["detail"]
    return body


def wav(seconds: float, rate: int = 16000) -> bytes:
    buf = io.BytesIO()
    t = np.arange(int(seconds * rate)) / rate
    sf.write(buf, 0.1 * np.sin(2 * np.pi * 220 * t), rate, format="WAV", subtype="PCM_16")
    return buf.getvalue()


# ----- meta --------------------------------------------------------------------------------
def test_healthz(client):
    body = client.get("/healthz").json()
    assert body["status"] == "ok" and body["scenarios"] >= 1 and "phonetic" in body["likelihoods"]


def test_openapi_documents_both_infer_bodies(client):
    spec = client.get("/openapi.json").json()
    content = spec["paths"]["/v1/infer"]["post"]["requestBody"]["content"]
    assert set(content) == {"application/json", "multipart/form-data"}
    assert "InferRequest" in spec["components"]["schemas"]
    assert set(Mode.__args__) == set(MODES)


def test_page_is_served_with_a_strict_policy(client):
    r = client.get("/")
    assert r.status_code == 200 and "<svg id=\"map\"" in r.text
    assert "default-src 'self'" in r.headers["content-security-policy"]
    assert client.get("/static/app.js").status_code == 200


def test_unknown_endpoint_is_a_problem(client):
    problem(client.get("/v2/nothing"), 404)


# ----- scenarios ---------------------------------------------------------------------------
def test_scenarios_list(client):
    ids = [s["id"] for s in client.get("/v1/scenarios").json()["scenarios"]]
    assert KITCHEN in ids and "household-table-v0/3" in ids


@pytest.mark.parametrize("path", ["household-table-v0/3", "household-table-v0%2F3"])
def test_scenario_ids_with_a_slash_work_raw_and_encoded(client, path):
    body = client.get(f"/v1/scenarios/{path}").json()
    assert body["id"] == "household-table-v0/3"
    assert len(body["timeline"]) == len(body["actions"]) + 1


def test_scenario_map_png(client, app):
    r = client.get("/v1/scenarios/household-table-v0%2F3.png")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png" and r.content[:4] == b"\x89PNG"
    assert client.get(f"/v1/scenarios/{KITCHEN}.png", params={"command": "fetch(sugar)"}).status_code == 200
    problem(client.get(f"/v1/scenarios/{KITCHEN}.png", params={"command": "fetch(unicorn)"}), 422)
    cached = list(app.state.runtime.map_dir.iterdir())
    assert cached and all(p.suffix == ".png" and len(p.stem) == 32 for p in cached)


def test_unknown_scenario_suggests_a_close_id(client):
    body = problem(client.get("/v1/scenarios/kitchen-cereal-v1"), 404)
    assert "Did you mean 'kitchen-cereal-v0'" in body["detail"]
    problem(client.get("/v1/scenarios/kitchen-cereal-v1.png"), 404)


@pytest.mark.parametrize("path", [
    "../../../../etc/passwd", "..%2F..%2F..%2Fetc%2Fpasswd", "%2e%2e/%2e%2e/etc/passwd",
    "/etc/passwd", "..%5C..%5Cwindows", "kitchen-cereal-v0/../../etc/passwd.png",
])
def test_path_traversal_is_only_a_registry_miss(client, path):
    r = client.get(f"/v1/scenarios/{path}")
    assert r.status_code in (404, 422), r.text
    assert "root:" not in r.text


def test_path_traversal_in_the_body_is_only_a_registry_miss(client):
    body = problem(client.post("/v1/infer", json={"scenario": "../../etc/passwd", "transcript": "x"}), 422)
    assert "unknown scenario" in body["detail"]


# ----- inference (JSON) --------------------------------------------------------------------
def test_infer_transcript(client):
    body = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "pass me the sugar"}).json()
    assert body["command"] == "fetch(sugar)"
    assert body["commands"][0] == {"command": "fetch(sugar)", "prob": pytest.approx(body["commands"][0]["prob"])}
    assert abs(sum(g["prob"] for g in body["goals"]) - 1) < 0.2
    assert body["nbest"] == [{"text": "pass me the sugar", "score": 0.0}]
    assert body["plan"]["route"][-1] == "kitchen_counter"
    assert set(body["clarification"]) >= {"ask", "question", "evi", "p_map"}


def test_infer_nbest_and_actions_only(client):
    nb = client.post("/v1/infer", json={"scenario": KITCHEN, "nbest": [
        {"text": "pass me the see real", "score": -1.0}, {"text": "pass me the sugar", "score": -6.0}]})
    assert nb.status_code == 200 and nb.json()["top_command"] == "fetch(cereal)"
    acts = client.post("/v1/infer", json={"scenario": KITCHEN, "n_actions": 0})
    assert acts.status_code == 200 and acts.json()["n_actions"] == 0 and acts.json()["nbest"] == []


def test_flat_posterior_gives_a_question(client):
    body = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "pass me the",
                                          "clarify": {"threshold": 0.99, "cost": 0.0}}).json()
    assert body["clarification"]["ask"] and body["clarification"]["question"].startswith("Did you mean")


@pytest.mark.parametrize("rule", ["map", "expected-benefit", "ask-or-act"])
def test_infer_with_a_decision_rule(client, rule):
    body = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "pass me the sugar",
                                          "decide": rule}).json()
    d = body["decision"]
    assert d["rule"] == rule and d["action"] in ("fetch(sugar)", "ask")
    assert d["benefits"] and d["benefits"][0]["expected_benefit"] >= 0


def test_unknown_decision_rule_is_422(client):
    r = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "x", "decide": "expected_benefit"})
    assert r.status_code == 422 and "decide" in r.text


def test_decision_rule_names_match_the_registry():
    from typing import get_args

    from siftom.assist.decide import RULES
    from siftom.service.schemas import DecisionRuleName

    assert set(get_args(DecisionRuleName)) == set(RULES)


def test_infer_custom_actions(client):
    sc = client.get(f"/v1/scenarios/{KITCHEN}").json()
    r = client.post("/v1/infer", json={"scenario": KITCHEN, "actions": sc["actions"][:3], "transcript": "the cereal"})
    assert r.status_code == 200 and r.json()["n_actions"] == 3
    body = problem(client.post("/v1/infer", json={"scenario": KITCHEN, "actions": ["fly(human, moon)"]}), 422)
    assert "fly" in body["detail"]


@pytest.mark.parametrize(("payload", "needle"), [
    ({"scenario": KITCHEN, "transcipt": "x"}, "transcipt"),
    ({"scenario": KITCHEN, "transcript": "x", "nbest": [{"text": "x"}]}, "not both"),
    ({"scenario": KITCHEN, "transcript": "   "}, "blank"),
    ({"scenario": KITCHEN, "mode": "psychic"}, "mode"),
    ({"scenario": KITCHEN, "likelihood": "telepathy", "transcript": "x"}, "telepathy"),
    ({"scenario": KITCHEN, "n_actions": 999}, "n_actions"),
    ({"scenario": KITCHEN, "n_actions": 50}, "between 0 and"),
    ({"scenario": KITCHEN, "mode": "speech-only"}, "needs an instruction"),
    ({"scenario": KITCHEN, "transcript": "x" * 501}, "transcript"),
    ({"scenario": KITCHEN, "nbest": []}, "nbest"),
    ({"scenario": KITCHEN, "top": 0}, "top"),
    ({"transcript": "x"}, "scenario"),
    ({"scenario": "kitchen-cerael-v0", "transcript": "x"}, "Did you mean 'kitchen-cereal-v0'"),
])
def test_bad_json_is_422_with_the_reason(client, payload, needle):
    assert needle in problem(client.post("/v1/infer", json=payload), 422)["detail"]


def test_malformed_json_and_nan(client):
    h = {"content-type": "application/json"}
    problem(client.post("/v1/infer", content=b"{not json", headers=h), 422)
    problem(client.post("/v1/infer", content=b'{"scenario": "kitchen-cereal-v0", "nbest": [{"text": "a", "score": NaN}]}',
                        headers=h), 422)


def test_wrong_media_type_is_415(client):
    problem(client.post("/v1/infer", content=b"pass me the sugar", headers={"content-type": "text/plain"}), 415)


def test_oversized_body_is_413_by_length_and_by_stream(client, app):
    limit = app.state.runtime.settings.max_body_bytes
    big = b'{"scenario": "' + b"x" * (limit + 10) + b'"}'
    problem(client.post("/v1/infer", content=big, headers={"content-type": "application/json"}), 413)

    def chunks():
        for _ in range(limit // 1000 + 5):
            yield b" " * 1000

    problem(client.post("/v1/infer", content=chunks(), headers={"content-type": "application/json"}), 413)


# ----- inference (audio) and speech --------------------------------------------------------
def test_say_then_infer_from_audio(client):
    r = client.post("/v1/say", json={"text": "can you pass me the cereal"})
    assert r.status_code == 200 and r.headers["content-type"] == "audio/wav" and r.content[:4] == b"RIFF"
    client.app.state.runtime.wait_warm()  # the default audio model loads at start (slow on a loaded machine)
    res = client.post("/v1/infer", data={"scenario": KITCHEN, "asr_nbest": "3"},
                      files={"audio": ("say.wav", r.content, "audio/wav")})
    body = res.json()
    assert res.status_code == 200, body
    assert body["asr"]["engine"].startswith("pocketsphinx") and 1 <= len(body["nbest"]) <= 3
    assert body["command"] == "fetch(cereal)"
    from siftom.likelihood.whisper_factor import whisper_available

    want = "acoustic" if whisper_available() else "phonetic"  # the default for a recording
    assert body["likelihood"] == want and body["evidence"]["likelihood"] == want
    assert body["degraded"] == ""  # one request at a time: the server was not crowded
    # past the CPU budget the default likelihood gives way to the phonetic one, and says so
    rt = client.app.state.runtime
    budget, rt.admission.budget = rt.admission.budget, 0
    try:
        with rt.admission.slot():
            rt.admission.budget = 1  # one utterance is being answered on a 1-CPU budget
            busy = client.post("/v1/infer", data={"scenario": KITCHEN},
                               files={"audio": ("say.wav", r.content, "audio/wav")}).json()
    finally:
        rt.admission.budget = budget
    assert busy["likelihood"] == "phonetic" and "1 utterances were being answered on 1 CPUs" in busy["degraded"]
    # the cheaper likelihood cannot know the full path agrees: it confirms before acting
    assert busy["action"] == "ask" and busy["command"] is None and busy["top_command"] == "fetch(cereal)"
    assert busy["decision"]["question"] == "Shall I get the cereal?"
    assert client.get("/healthz").json()["admission"]["degraded"] >= 1
    text = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "pass me the cereal"}).json()
    assert text["likelihood"] == "phonetic" and text["evidence"]["likelihood_reason"].startswith("no audio")


def test_noisy_audio_scored_acoustically_uses_the_audio_and_leaves_no_file(client, tmp_path):
    # in noise the transcript often loses the object word; the audio itself still carries it
    # (the demo's clip: the same answer over HTTP as from `siftom demo`)
    r = client.post("/v1/say", json={"text": "can you pass me the cereal", "noise": "pink", "snr": 5, "seed": 1})
    res = client.post("/v1/infer", data={"scenario": KITCHEN, "likelihood": "acoustic"},
                      files={"audio": ("say.wav", r.content, "audio/wav")})
    body = res.json()
    assert res.status_code == 200, body
    # the robot carries out fetch(cereal) or asks a question that names the cereal
    assert body["likelihood"] == "acoustic" and body["top_command"] == "fetch(cereal)"
    assert (body["action"] == "act" and body["command"] == "fetch(cereal)") or (
        body["action"] == "ask" and "fetch(cereal)" in body["decision"]["options"]), body["decision"]
    phon = client.post("/v1/infer", data={"scenario": KITCHEN, "likelihood": "phonetic"},
                       files={"audio": ("say.wav", r.content, "audio/wav")}).json()
    assert phon["top_command"] != "fetch(cereal)"  # the words alone point elsewhere: the audio decided
    uploads = client.app.state.runtime.data_dir / "uploads"
    assert not uploads.exists() or not any(uploads.iterdir())
    # the library, with its defaults, hears the same clip the same way (one default N-best size)
    clip = tmp_path / "say.wav"
    clip.write_bytes(r.content)
    for lik, answer in (("acoustic", body), ("phonetic", phon)):
        heard = siftom.listen(clip, KITCHEN, likelihood=lik)
        assert [h.text for h in heard.asr.nbest] == [h["text"] for h in answer["nbest"]], lik
        assert str(heard.top_command) == answer["top_command"] and heard.action == answer["action"], lik


def test_a_background_talker_in_babble_is_not_taken_for_a_wrong_fetch(client):
    # babble at 10 dB: the words alone fetch the wrong object; with the audio, Whisper writes the
    # background talker's words, and the robot does nothing rather than fetch something else
    r = client.post("/v1/say", json={"text": "can you pass me the cereal", "noise": "babble", "snr": 10, "seed": 0})
    got = {lik: client.post("/v1/infer", data={"scenario": KITCHEN, "likelihood": lik},
                            files={"audio": ("say.wav", r.content, "audio/wav")}).json()
           for lik in ("acoustic", "phonetic")}
    # the words alone point at another object: not carried out as the cereal (asked about, or wrong)
    assert got["phonetic"]["top_command"] != "fetch(cereal)" and got["phonetic"]["command"] != "fetch(cereal)"
    acoustic = got["acoustic"]
    assert acoustic["command"] in (None, "fetch(cereal)"), acoustic["decision"]


@pytest.mark.parametrize("likelihood", ["phonetic", "acoustic"])
def test_silence_upload_says_no_speech_and_uses_the_actions(client, likelihood):
    buf = io.BytesIO()
    sf.write(buf, np.zeros(32_000, dtype=np.float32), 16_000, format="WAV", subtype="PCM_16")
    res = client.post("/v1/infer", data={"scenario": KITCHEN, "likelihood": likelihood},
                      files={"audio": ("silence.wav", buf.getvalue(), "audio/wav")})
    body = res.json()
    assert res.status_code == 200, body
    assert body["speech_heard"] is False and body["message"] == "no speech heard"
    assert body["mode"] == "action-only" and body["transcript"] == "" and body["nbest"] == []
    ref = client.post("/v1/infer", json={"scenario": KITCHEN, "mode": "action-only"}).json()
    assert body["command"] == ref["command"]


def test_acoustic_likelihood_without_audio_is_a_clear_422(client):
    res = client.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "pass me the cereal",
                                          "likelihood": "acoustic"})
    assert res.status_code == 422 and "needs the audio" in res.json()["detail"]


def test_say_with_noise(client):
    r = client.post("/v1/say", json={"text": "pass me the sugar", "noise": "babble", "snr": 0, "seed": 3})
    assert r.status_code == 200 and len(r.content) > 1000


@pytest.mark.parametrize("payload", [
    {"text": "hi", "voice": "hal-9000"}, {"text": "hi", "noise": "/etc/passwd"}, {"text": ""},
    {"text": "hi", "snr": 1e9}, {"text": "hi", "rate": 0},
])
def test_bad_say_is_422(client, payload):
    problem(client.post("/v1/say", json=payload), 422)


def test_bad_audio_uploads(client):
    def post(data, files):
        return client.post("/v1/infer", data=data, files=files)

    problem(post({"scenario": KITCHEN}, {"audio": ("x.wav", b"not audio at all", "audio/wav")}), 422)
    problem(post({"scenario": KITCHEN}, {"audio": ("x.wav", b"", "audio/wav")}), 422)
    assert "allowed" in problem(post({"scenario": KITCHEN}, {"audio": ("x.wav", wav(6.0, 8000), "audio/wav")}), 422)["detail"]
    problem(post({"scenario": KITCHEN}, {"other": ("x.wav", wav(0.5), "audio/wav")}), 422)
    problem(post({"scenario": "nope"}, {"audio": ("x.wav", wav(0.5), "audio/wav")}), 422)
    problem(post({"scenario": KITCHEN, "bogus": "1"}, {"audio": ("x.wav", wav(0.5), "audio/wav")}), 422)
    problem(post({"scenario": KITCHEN}, {"audio": ("x.wav", wav(10.0, 16000), "audio/wav")}), 413)


def test_upload_filename_is_never_used_as_a_path(client, app, tmp_path):
    before = set(app.state.runtime.data_dir.rglob("*"))
    r = client.post("/v1/infer", data={"scenario": KITCHEN},
                    files={"audio": ("../../../../tmp/siftom-evil.wav", wav(0.5), "audio/wav")})
    assert r.status_code in (200, 422)
    assert set(app.state.runtime.data_dir.rglob("*")) == before


# ----- limits and concurrency --------------------------------------------------------------
def test_request_time_limit_is_503(tmp_path):
    slow = create_app(tmp_path, ServiceSettings(request_timeout_s=1e-6))
    with local_client(slow) as c:
        r = c.post("/v1/infer", json={"scenario": KITCHEN, "transcript": "the sugar"})
    assert problem(r, 503)["type"].endswith("timeout") and r.headers["retry-after"]


def test_concurrent_requests_give_the_same_answers(app):
    import httpx

    cases = [(KITCHEN, "pass me the sugar"), (KITCHEN, "the cereal please"), ("household-table-v0/3", "bring the forks"),
             ("kitchen-v0/2", "get me the milk")] * 6
    with serve_in_thread(app) as url, httpx.Client(base_url=url, timeout=30) as c:
        def one(case):
            r = c.post("/v1/infer", json={"scenario": case[0], "transcript": case[1]})
            return r.status_code, r.json()["commands"][:3]

        serial = [one(k) for k in cases]
        with ThreadPoolExecutor(8) as pool:
            parallel = list(pool.map(one, cases))
    assert all(s == 200 for s, _ in serial)
    assert [cmds for _, cmds in parallel] == [cmds for _, cmds in serial]
