"""StreamListener: recognition starts before the end is declared and is reused, an answer is
computed early only while the state token holds, and an utterance without words is not answered."""

from __future__ import annotations

import threading
import time

import numpy as np

from siftom.inference.stream import NO_WORDS, Recognised, StreamListener
from siftom.observation import Hypothesis, Instruction
from siftom.speech.segment import FRAME, SpeechEnded


class Scripted:
    def __init__(self, probs):
        self.probs, self.k = list(probs), 0

    def __call__(self, frame):
        p = self.probs[self.k] if self.k < len(self.probs) else 0.0
        self.k += 1
        return p

    def reset(self):
        self.k = 0


class Body(dict):
    def to_json(self):
        return dict(self)


def _feed(listener, n):
    out = []
    for _ in range(n):
        out += listener.feed(np.zeros(FRAME, np.float32))
        time.sleep(0.002)
    return [e for e in out if isinstance(e, SpeechEnded)]


def test_early_recognition_and_answer_are_reused_while_nothing_changed():
    calls = {"rec": 0, "ans": 0}
    version = [0]

    def recognise(samples):
        calls["rec"] += 1
        return Recognised(Instruction(nbest=(Hypothesis("pass the milk", 0.0),)), None, 0.01)

    def answer(rec, utt):
        calls["ans"] += 1
        return Body(command="fetch(milk)", decision="act", seen=version[0])

    lst = StreamListener(recognise, answer, scorer=Scripted([0.9] * 10 + [0.0] * 20), version=lambda: version[0])
    (end,) = _feed(lst, 30)
    out = lst.respond(end.utterance).to_json()
    assert out["event"] == "decision" and out["heard"] == "" and out["command"] == "fetch(milk)"
    assert out["timings"]["asr_early"] and out["timings"]["answer_early"]
    assert calls == {"rec": 1, "ans": 1}
    lst.close()


def test_an_action_meanwhile_makes_the_early_answer_stale():
    version = [0]
    seen = []

    def answer(rec, utt):
        seen.append(version[0])
        return Body(n=version[0])

    rec = Recognised(Instruction(nbest=(Hypothesis("milk", 0.0),)), None, 0.0)
    lst = StreamListener(lambda s: rec, answer, scorer=Scripted([0.9] * 10 + [0.0] * 20), version=lambda: version[0])
    (end,) = _feed(lst, 30)
    version[0] = 1  # an action arrived after the early answer
    out = lst.respond(end.utterance).to_json()
    assert out["n"] == 1 and not out["timings"]["answer_early"] and seen == [0, 1]
    lst.close()


def test_without_a_version_the_answer_runs_once_after_the_end():
    seen = []
    gate = threading.Event()

    def answer(rec, utt):
        seen.append(utt.reason)
        gate.set()
        return Body()

    rec = Recognised(Instruction(nbest=(Hypothesis("milk", 0.0),)), None, 0.0)
    lst = StreamListener(lambda s: rec, answer, scorer=Scripted([0.9] * 10 + [0.0] * 20))
    (end,) = _feed(lst, 30)
    assert not gate.is_set()
    lst.respond(end.utterance)
    assert seen == ["silence"]
    lst.close()


def test_an_utterance_without_words_is_not_answered():
    lst = StreamListener(lambda s: Recognised(None, None, 0.0, NO_WORDS), lambda r, u: Body(never=True),
                         scorer=Scripted([0.9] * 10), early=False)
    _feed(lst, 12)
    (end,) = lst.finish()
    out = lst.respond(end.utterance).to_json()
    assert out["event"] == "no_speech" and out["message"] == NO_WORDS and "never" not in out
