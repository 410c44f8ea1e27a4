"""Nobody asked: words that hold no request are no instruction, by the utterance model's own weight
(siftom.language.understand, with the chance levels of likelihood/nearness.py)."""

from __future__ import annotations

import shutil

import pytest

from helpers import model_for
from siftom.api import make_instruction
from siftom.assist.decide import Situation, decide
from siftom.language.understand import understand
from siftom.likelihood.nearness import CHANCE_QUANTILE
from siftom.scenarios.base import get_scenario


def _online(sid: str):
    sc = get_scenario(sid)
    on = model_for("full", "phonetic").online(sc.world, sc.start, sc.goals, sc.verb)
    for a in sc.actions:
        on.observe(a)
    return sc, on


def _commands(sid: str):
    return _online(sid)[1].candidates()[4]


def _asked(sid: str, heard: str) -> bool:
    classes = sorted({c.obj_class for c in _commands(sid)})
    return understand([heard], [1.0], classes).request


@pytest.mark.parametrize("heard", ["the panel of", "i have the puck", "what", "hand", "would i'm missing",
                                   "thanks", "the weather is nice today", "where did i leave my keys",
                                   "don't bring the sugar", "my phone battery is dead"])
def test_what_a_recogniser_made_of_noise_or_room_talk_is_no_request(heard):
    assert not _asked("kitchen-cereal-v0", heard)


@pytest.mark.parametrize("sid, heard", [("kitchen-cereal-v0", "can you pass me the serial"),
                                        ("kitchen-cereal-v0", "could you grab the olive oil please"),
                                        ("household-table-v0/3", "bring me three forks"),
                                        ("kitchen-cereal-v0", "pass me the silver"),
                                        ("kitchen-cereal-v0", "we still need the")])
def test_instructions_and_near_misses_are_requests(sid, heard):
    assert _asked(sid, heard)


def test_the_chance_level_holds_on_words_it_was_not_measured_on():
    import numpy as np

    from siftom.likelihood.nearness import chance_threshold, scene_words, word_costs
    from siftom.likelihood.phonemes import cmudict

    # other words (seed 7; the levels came from seed 0): about 1 % count as near by chance
    pool = sorted(w for w in cmudict() if w.isalpha() and len(w) > 2)
    words = [pool[i] for i in np.random.default_rng(7).choice(len(pool), 400, replace=False)]
    near = total = 0
    for sid in ("kitchen-cereal-v0", "household-table-v0/3"):
        sw = scene_words(_commands(sid))
        for w in words:
            for _w, k, r in word_costs(w, sw):
                total += 1
                near += r <= chance_threshold(k)
    assert total > 500 and near / total <= 3 * CHANCE_QUANTILE


def test_the_posterior_says_so_and_the_decision_rules_do_nothing():
    sc, on = _online("kitchen-cereal-v0")
    post = on.posterior(make_instruction("the panel of"))
    assert post.evidence["no_instruction"] is True and post.understanding is not None
    assert not post.understanding.request and post.understanding.p_request < 0.5
    assert "the panel of" in post.evidence["no_instruction_reason"]
    where = Situation.from_scenario(sc)
    for rule in ("map", "expected-benefit", "ask-or-act"):
        d = decide(post, where, rule)
        assert d.action == "none" and "no instruction heard" in d.reason
    said = on.posterior(make_instruction("can you pass me the cereal"))
    assert "no_instruction" not in said.evidence
    assert decide(said, where, "map").action == said.command


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_listen_issues_no_command_for_words_that_hold_none(tmp_path, capsys):
    from siftom.api import listen
    from siftom.cli import main
    from siftom.speech.tts import synthesize

    x = synthesize("what time is it", "flite-slt")
    heard = listen(x, scenario="kitchen-cereal-v0")
    assert heard.speech and not heard.instruction
    assert heard.command is None and heard.action == "none" and heard.message == "no instruction heard"
    assert heard.posterior.mode == "action-only"  # the actions-alone belief is still shown
    js = heard.to_json()
    assert js["command"] is None and js["action"] == "none" and js["instruction_heard"] is False
    assert js["evidence"]["no_instruction"] and js["decision"]["reason"].startswith("no instruction heard")
    import soundfile as sf

    wav = tmp_path / "x.wav"
    sf.write(wav, x, 16000)
    assert main(["infer", "--scenario", "kitchen-cereal-v0", "--audio", str(wav)]) == 0
    out = capsys.readouterr().out
    assert "no instruction heard" in out and "the robot does nothing" in out
