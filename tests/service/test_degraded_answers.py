"""Under load an utterance is scored by the cheaper likelihood; its answer may lose confidence but
never turns a decline or a question into an action (service/admission.py's AskFirst)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from siftom.inputs import resolve_scene
from siftom.observation import Instruction
from siftom.observer import Observer
from siftom.service.admission import DEGRADED_LIKELIHOOD, AskFirst, Slot

ROOT = Path(__file__).parents[2]
SALAD = ROOT / "docs" / "examples" / "salad"
ACTIONS = [ln for ln in (SALAD / "actions.txt").read_text().splitlines() if ln.strip() and not ln.startswith("#")]
DEGRADED = Slot(DEGRADED_LIKELIHOOD, "answered with the phonetic likelihood: 2 utterances were being answered")


@pytest.fixture(scope="module")
def observer() -> Observer:
    return Observer()


@pytest.fixture(scope="module")
def salad(observer: Observer):
    return observer.online(resolve_scene(str(SALAD / "world.json"), ACTIONS))


def _answer(observer: Observer, online, words: str, rule, **kw):
    return observer.answer(online, Instruction.from_text(words), likelihood=DEGRADED_LIKELIHOOD, decide=rule, **kw)


def test_a_slot_within_the_budget_keeps_the_rule_it_was_given(observer):
    idle = Slot(None, "")
    assert idle.rule(None, observer.settings) is None and idle.rule("map", observer.settings) == "map"
    wrapped = DEGRADED.rule(None, observer.settings)
    assert isinstance(wrapped, AskFirst) and wrapped.base == observer.settings.infer.decide
    assert wrapped.name == observer.settings.infer.decide


def test_an_action_the_cheaper_likelihood_would_take_becomes_a_question_and_yes_carries_it_out(observer, salad):
    # "pass me the cereal" where there is no cereal: the scene-biased recogniser hears the bowl
    rule = DEGRADED.rule(None, observer.settings)
    acting = _answer(observer, salad, "pass me the bowl", None)
    assert acting.action == "act" and str(acting.command) == "fetch(bowl)"  # the rule alone would act
    asked = _answer(observer, salad, "pass me the bowl", rule)
    assert asked.action == "ask" and asked.command is None
    assert asked.decision.question == "Shall I get the bowl?" and asked.decision.question_kind == "confirm"
    assert asked.decision.rule == acting.decision.rule and "under load" in asked.decision.reason
    assert asked.pending is not None  # the robot waits on the answer, as for any question
    yes = _answer(observer, salad, "yes", rule, pending=asked.pending)
    assert yes.action == "act" and str(yes.command) == "fetch(bowl)"  # confirmed: not asked twice
    no = _answer(observer, salad, "no", rule, pending=asked.pending)
    assert no.action != "act" and no.command is None, no.decision  # not confirmed: not carried out


def test_a_decline_and_a_question_stay_what_they_are(observer, salad):
    rule = DEGRADED.rule(None, observer.settings)
    plain = _answer(observer, salad, "pass me the cereal", None)
    kept = _answer(observer, salad, "pass me the cereal", rule)
    assert plain.action == "none" and plain.decision.declined  # no cereal here: declined, with the reason
    assert kept.decision.to_json() == plain.decision.to_json()
    table = observer.online(resolve_scene("household-table-v0/0"))
    unsure = _answer(observer, table, "get the bowls", None)  # how many: the rule asks
    assert unsure.action == "ask" and unsure.decision.question == "How many bowls?"
    assert _answer(observer, table, "get the bowls", rule).decision.to_json() == unsure.decision.to_json()


def test_a_degraded_recording_on_a_session_asks_before_acting(client):
    """The salad world over HTTP: a session's recording answered past the CPU budget."""
    rt = client.app.state.runtime
    sid = client.post("/v1/sessions", json={"world": json.loads((SALAD / "world.json").read_text())}).json()["id"]
    assert client.post(f"/v1/sessions/{sid}/actions", json={"actions": ACTIONS}).status_code == 200
    wav = client.post("/v1/say", json={"text": "pass me the bowl"}).content  # idle, the robot would fetch it
    budget, rt.admission.budget = rt.admission.budget, 0
    try:
        with rt.admission.slot():
            rt.admission.budget = 1  # one utterance is being answered on a 1-CPU budget
            r = client.post(f"/v1/sessions/{sid}/instruction", files={"audio": ("say.wav", wav, "audio/wav")})
    finally:
        rt.admission.budget = budget
    body = r.json()
    assert r.status_code == 200, body
    assert "bowl" in body["transcript"] and body["degraded"]  # scored by the cheaper likelihood
    assert body["likelihood"] == DEGRADED_LIKELIHOOD
    assert body["action"] == "ask" and body["command"] is None, body["decision"]
    assert body["decision"]["question"] == "Shall I get the bowl?" and body["awaiting"] is not None


def test_a_degraded_speech_only_answer_asks_before_acting(observer, salad):
    # speech-only inference has no state to value actions in, so no rule runs: it confirms anyway
    rule = DEGRADED.rule(None, observer.settings)
    idle = _answer(observer, salad, "pass me the bowl", None, mode="speech-only")
    assert idle.action == "act" and str(idle.command) == "fetch(bowl)"
    asked = _answer(observer, salad, "pass me the bowl", rule, mode="speech-only")
    assert asked.action == "ask" and asked.command is None and asked.decision.question == "Shall I get the bowl?"
