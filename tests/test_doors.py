"""Door conformance: one table of observations through every door, under a non-default settings
file, gives the same posterior and the same decision (as Gymnasium's check_env runs one check on
every environment).

Doors: ``siftom.infer`` / ``siftom.listen`` (Python), ``siftom infer`` (CLI), ``POST /v1/infer``,
a session's instruction (JSON and audio), the WebSocket stream and the listener behind ``siftom
listen`` and the ROS bridge. Nothing here may be answered with a command nobody asked for.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")
ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets: pip install 'siftom[stream]'")

import httpx  # noqa: E402
from click.testing import CliRunner  # noqa: E402

import siftom  # noqa: E402
from siftom.cli import root  # noqa: E402
from siftom.listener import HomeListener, load_home  # noqa: E402
from siftom.observer import Observer  # noqa: E402
from siftom.service.app import create_app  # noqa: E402
from siftom.service.local_server import serve_in_thread  # noqa: E402
from siftom.settings import Settings  # noqa: E402
from support.streaming import Collector, pcm16, say, silence, stream  # noqa: E402

SCENARIO = "kitchen-cereal-v0"
SETTINGS_FILE = "[model]\nunknown_prior = 0.3\nbetas = [8.0]\n"
TOL = 1e-9

# (name, what was heard, whether the robot may act)
TEXTS = [
    ("transcript", "pass me the silver", None),
    ("clear request", "can you pass me the cereal", True),
    ("off-topic", "the weather is really nice today", False),
    ("room talk", "need an", False),
    ("correction", "no, not the sugar, the honey", None),
    ("several things", "could you get me the cereal and the sugar", None),
    ("repair with no edit term", "the jam the honey", None),
    ("more than the world holds", "bring me three bowls", None),
]
NBEST = [{"text": "pass me the silver", "score": -1.0}, {"text": "pass me the cereal", "score": -3.0}]


@pytest.fixture(scope="module")
def config(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("doors") / "siftom.toml"
    path.write_text(SETTINGS_FILE, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def settings(config: Path) -> Settings:
    return Settings.load(config, env={})


@pytest.fixture(scope="module")
def clips(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("clips")
    out = {"request": d / "request.wav", "off-topic": d / "offtopic.wav", "silence": d / "silence.wav",
           "request-in-a-pause": d / "pause.wav"}
    say("can you pass me the cereal", out["request"])
    say("the weather is really nice today", out["off-topic"])
    import soundfile as sf

    # the request with room before and after it: where a door cuts the speech out matters here
    x, _ = sf.read(out["request"], dtype="float32")
    sf.write(out["request-in-a-pause"], np.concatenate([silence(0.7), x, silence(0.9)]), 16_000, subtype="PCM_16")

    sf.write(out["silence"], np.zeros(32_000, dtype=np.float32), 16_000)
    return out


@pytest.fixture(scope="module")
def server(settings: Settings, tmp_path_factory: pytest.TempPathFactory):
    app = create_app(tmp_path_factory.mktemp("serve"), settings)
    with serve_in_thread(app) as url:
        yield url


def _cli(config: Path, *args: str) -> dict:
    res = CliRunner().invoke(root, ["infer", "--scenario", SCENARIO, "--config", str(config), "--json", *args])
    assert res.exit_code == 0, res.output
    return json.loads(res.output[res.output.index("{"):])


def _session(url: str) -> str:
    got = httpx.post(url + "/v1/sessions/from-scenario", json={"scenario": SCENARIO}, timeout=60)
    got.raise_for_status()
    return str(got.json()["id"])


def _same(answers: dict[str, dict], may_act: bool | None) -> None:
    """Every door's answer: the same top command, P(top) to 1e-9, the same action and command."""
    ref_name, ref = next(iter(answers.items()))
    for name, a in answers.items():
        assert a["top_command"] == ref["top_command"], (name, ref_name, a["top_command"], ref["top_command"])
        assert abs(a["top_prob"] - ref["top_prob"]) <= TOL, (name, a["top_prob"], ref["top_prob"])
        assert a["action"] == ref["action"] and a["command"] == ref["command"], (name, a["action"], ref["action"])
        assert a["decision"]["rule"] == ref["decision"]["rule"]
        # who heard it and what decided: the same recogniser, likelihood and rule named at every door
        for key in ("recogniser", "likelihood", "rule"):
            assert key in a and a[key] == ref[key], (name, key, a.get(key), ref.get(key))
        assert a["rule"] == a["decision"]["rule"]
        # what was understood: the same record, parts and commands carried out at every door
        for key in ("understanding", "parts", "carry_out"):
            assert a.get(key) == ref.get(key), (name, key, a.get(key), ref.get(key))
    if may_act is False:
        assert ref["action"] == "none" and ref["command"] is None, ref["decision"]
    if may_act is True:
        assert ref["action"] == "act" and ref["command"] == "fetch(cereal)", ref["decision"]


def _word_doors(text: str, config: Path, settings: Settings, server: str) -> dict[str, dict]:
    """``text`` through every door that takes words: each door's answer as JSON."""
    return {
        "python": siftom.infer(SCENARIO, None, text, settings=settings).to_json(),
        "observer": Observer(settings).infer(SCENARIO, None, text).to_json(),
        "cli": _cli(config, "--transcript", text),
        "http": httpx.post(server + "/v1/infer", json={"scenario": SCENARIO, "transcript": text},
                           timeout=60).raise_for_status().json(),
        "session": httpx.post(server + f"/v1/sessions/{_session(server)}/instruction", json={"transcript": text},
                              timeout=60).raise_for_status().json(),
        "listener": HomeListener(load_home(SCENARIO), observer=Observer(settings)).answer_text(text).to_json(),
    }


@pytest.mark.parametrize(("name", "text", "may_act"), TEXTS, ids=[t[0] for t in TEXTS])
def test_words_get_one_answer_through_every_door(name, text, may_act, config, settings, server):
    _same(_word_doors(text, config, settings, server), may_act)


def test_an_nbest_list_gets_one_answer_through_every_door(config, settings, server, tmp_path):
    pairs = [(h["text"], h["score"]) for h in NBEST]
    nb = tmp_path / "nbest.json"
    nb.write_text(json.dumps(NBEST), encoding="utf-8")
    answers = {
        "python": siftom.infer(SCENARIO, None, pairs, settings=settings).to_json(),
        "cli": _cli(config, "--nbest", str(nb)),
        "http": httpx.post(server + "/v1/infer", json={"scenario": SCENARIO, "nbest": NBEST},
                           timeout=60).raise_for_status().json(),
        "session": httpx.post(server + f"/v1/sessions/{_session(server)}/instruction", json={"nbest": NBEST},
                              timeout=60).raise_for_status().json(),
    }
    _same(answers, None)


def _streamed(url: str, samples: np.ndarray) -> dict | None:
    """The WebSocket's decision event for ``samples`` (None when it found no utterance to answer):
    float samples with silence before and after, as a microphone would give them, or a recording's
    own 16-bit samples exactly as they are."""
    sid = _session(url)
    with ws_client.connect(url.replace("http://", "ws://") + f"/v1/sessions/{sid}/listen") as ws:
        got = Collector(ws)
        got.ready()
        data = (samples.astype("<i2").tobytes() if samples.dtype == np.int16
                else pcm16(np.concatenate([silence(0.3), samples, silence(1.0)])))
        stream(ws, data, chunk_ms=20)
        ws.send(json.dumps({"type": "end"}))
        got.wait(timeout=120)
    events = [e for e in got.events if e["event"] in ("decision", "no_speech")]
    return events[-1] if events else None


@pytest.mark.parametrize(("clip", "may_act"), [("request", True), ("request-in-a-pause", True), ("off-topic", False),
                                               ("silence", False)])
def test_a_recording_gets_one_answer_through_every_door(clip, may_act, clips, config, settings, server):
    import soundfile as sf

    path = clips[clip]
    data = path.read_bytes()
    answers = {
        "python": siftom.infer(SCENARIO, None, str(path), settings=settings).to_json(),
        "listen": siftom.listen(str(path), SCENARIO, settings=settings).to_json(),
        "cli": _cli(config, "--audio", str(path)),
        "http": httpx.post(server + "/v1/infer", data={"scenario": SCENARIO},
                           files={"audio": ("a.wav", data, "audio/wav")}, timeout=120).raise_for_status().json(),
        "session": httpx.post(server + f"/v1/sessions/{_session(server)}/instruction",
                              files={"audio": ("a.wav", data, "audio/wav")}, timeout=120).raise_for_status().json(),
    }
    _same(answers, may_act)
    # the stream cuts the utterance with its own detector: the same decision, whatever the cut
    x, _ = sf.read(path, dtype="float32")
    event = _streamed(server, x)
    if may_act:
        assert event is not None and event["event"] == "decision"
        assert event["action"] == answers["python"]["action"] and event["command"] == answers["python"]["command"]
    else:
        assert event is None or event["event"] == "no_speech" or (event["action"] == "none"
                                                                    and event["command"] is None), event
    # the same recording streamed in 20 ms chunks is heard exactly as when it is sent whole: one cut
    exact = _streamed(server, sf.read(path, dtype="int16")[0])
    if answers["session"]["speech_heard"]:
        assert exact is not None and exact["event"] == "decision", exact
        assert (exact["action"], exact["command"], exact["heard"]) == (
            answers["session"]["action"], answers["session"]["command"], answers["session"]["asr"]["text"])
        assert [c["prob"] for c in exact["commands"]] == pytest.approx(
            [c["prob"] for c in answers["session"]["commands"]], abs=1e-6)
        # the recogniser heard the very same samples: the same N-best, score for score
        assert [(h["text"], round(h["score"], 3)) for h in exact["nbest"]] == [
            (h["text"], round(h["score"], 3)) for h in answers["session"]["nbest"]]
    else:
        assert exact is None or exact["event"] == "no_speech", exact


def test_the_readme_example_is_carried_out_or_asked_about_naming_the_cereal_at_every_door(config, settings, server):
    answers = _word_doors("pass me the silver", config, settings, server)
    _same(answers, None)
    for name, a in answers.items():
        assert (a["action"] == "act" and a["command"] == "fetch(cereal)") or (
            a["action"] == "ask" and "cereal" in a["decision"]["question"]), (name, a["decision"])


def test_a_question_and_its_reply_get_one_answer_through_every_conversation_door(settings, server):
    """The robot asks; the person's reply goes back through each door that keeps a conversation."""
    first = siftom.infer(SCENARIO, None, "pass me the silver", settings=settings)
    assert first.action == "ask" and first.pending is not None, first.decision
    reply = first.decision.asked.answers[0][0]  # the plainest answer naming the first option
    sid = _session(server)
    home = HomeListener(load_home(SCENARIO), observer=Observer(settings))
    turns = {
        "python": [first.to_json(), siftom.infer(SCENARIO, None, reply, settings=settings,
                                                 pending=first.pending).to_json()],
        "session": [httpx.post(server + f"/v1/sessions/{sid}/instruction", json={"transcript": t},
                               timeout=60).raise_for_status().json() for t in ("pass me the silver", reply)],
        "listener": [home.answer_text(t).to_json() for t in ("pass me the silver", reply)],
    }
    _same({k: v[0] for k, v in turns.items()}, None)
    _same({k: v[1] for k, v in turns.items()}, None)
    for name, (ask, done) in turns.items():
        assert ask["awaiting_reply"] is True and done["awaiting_reply"] is False, name
        assert done["reply_to"] == ask["decision"]["question"], name
        assert done["action"] == "act" and done["command"] == first.decision.options[0], (name, done["decision"])


def test_the_settings_file_changes_the_answer(settings):
    with_file = siftom.infer(SCENARIO, None, "pass me the silver", settings=settings)
    without = siftom.infer(SCENARIO, None, "pass me the silver", settings=Settings.load(env={}))
    assert abs(with_file.top_prob - without.top_prob) > 1e-4


def test_the_server_reports_the_settings_it_runs_with(server):
    got = httpx.get(server + "/healthz", timeout=30).json()["settings"]
    assert got["model.unknown_prior"] == 0.3 and got["model.betas"] == [8.0]
    assert got["infer.decide"] == "teammate"


@pytest.mark.parametrize("model", ["siftom-phonetic", "speech-only", "action-only", "siftom-oracle-text"])
def test_the_evaluator_answers_what_it_heard_as_the_python_door_does(model):
    """The evaluator is a door: a SIFToM model's choice for a stimulus is the Python door's answer to
    the same actions and words under the evaluator's settings (the paper's metric: the MAP rule)."""
    from siftom.bench.choosers import Trial, TrialHeard, choose
    from siftom.bench.models import EvalOptions, eval_model, eval_settings
    from siftom.observation import Instruction
    from siftom.people.stimuli import Stimulus, scenario_for
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(SCENARIO)
    s = Stimulus(id="t", scenario=SCENARIO, domain=sc.domain,
                 observed_actions=tuple(sc.world.format_action(a) for a in sc.actions), audio="t.wav",
                 reference="could you pass me the cereal", gold_goal={"name": sc.goal.name, "counts": {}},
                 gold_command=str(sc.command), speaker="s1", voice="flite-slt")
    heard = TrialHeard(EvalOptions(models=(model,)), (), Path("t.wav"), {"text": NBEST[0]["text"], "nbest": NBEST})
    spec = eval_model(model)
    command, prob, _extra = choose(Trial(spec, s, scenario_for(s), "k", heard, "."))

    said = {"nbest": Instruction.from_nbest([(h["text"], h["score"]) for h in NBEST]),
            "reference": s.reference, "none": None}[spec.heard if spec.mode != "action-only" else "none"]
    door = siftom.infer(SCENARIO, None, said, likelihood="phonetic", decide="map", settings=eval_settings(spec.mode))
    assert command == str(door.top_command)
    assert prob == pytest.approx(door.top_prob, abs=TOL)
