"""An answer that writes state (a session's) is prepared early and written at the end; one made
stale by an action meanwhile is prepared again; a closed stream writes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import SiftomError
from siftom.inference.stream import COMMIT_TRIES, Recognised, StreamListener
from siftom.observation import Hypothesis, Instruction
from siftom.speech.segment import Utterance


class Body(dict):
    def to_json(self):
        return dict(self)


def _listener(state: dict, stale: int):
    def recognise(samples):
        return Recognised(Instruction(nbest=(Hypothesis("pass me the cereal", 0.0),)), None, 0.0)

    def answer(rec, utt):
        state["prepared"] += 1
        return Body(revision=state["revision"])

    def commit(body):
        if state["stale"] < stale:  # an action arrived after this answer was prepared
            state["stale"] += 1
            state["revision"] += 1
            return None
        state["stored"].append(body)
        return Body(body, stored=True)

    return StreamListener(recognise, answer, early=False, version=lambda: state["revision"], commit=commit)


def _utt():
    return Utterance(0, np.zeros(16000, dtype=np.float32), 0.0, 1.0, 1.3, "silence")


def test_a_prepared_answer_is_written_once():
    state = {"prepared": 0, "revision": 0, "stale": 0, "stored": []}
    out = _listener(state, stale=0).respond(_utt()).to_json()
    assert out["event"] == "decision" and out["stored"] and state["prepared"] == 1 and len(state["stored"]) == 1


def test_an_answer_made_stale_by_an_action_is_prepared_again_with_the_new_state():
    state = {"prepared": 0, "revision": 0, "stale": 0, "stored": []}
    out = _listener(state, stale=1).respond(_utt()).to_json()
    assert state["prepared"] == 2 and out["revision"] == 1 and state["stored"] == [{"revision": 1}]


def test_a_state_that_never_settles_is_an_error_not_a_stale_answer():
    state = {"prepared": 0, "revision": 0, "stale": 0, "stored": []}
    with pytest.raises(SiftomError, match="say it again"):
        _listener(state, stale=COMMIT_TRIES).respond(_utt())
    assert state["stored"] == []
