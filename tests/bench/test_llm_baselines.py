"""LLM baselines: candidate scoring, prompts, and configuration errors (no real LLM needed)."""

from __future__ import annotations

import pytest

from siftom.bench import llm_baselines as lb
from siftom.errors import BackendUnavailableError
from siftom.scenarios.base import get_scenario


class WordMatchScorer:
    """A stand-in LM: log-prob 0 for a command description that names a word of the prompt."""

    model_id = "fake"

    def __init__(self) -> None:
        self.prefixes: list[str] = []

    def score(self, prefix, items):
        self.prefixes.append(prefix)
        heard = prefix.rsplit("Heard:", 1)[1]
        return [0.0 if any(w in heard for w in target.replace(")", " ").replace(",", " ").split() if len(w) > 3)
                else -5.0 for _ctx, target in items]


def test_end_to_end_picks_the_command_the_model_scores_highest():
    sc = get_scenario("kitchen-cereal-v0")
    ch = lb.LLMChooser(WordMatchScorer(), with_context=False)
    cmd, p = ch.choose(sc, "can you pass me the cereal", lb.command_space(sc))
    assert cmd == "fetch(cereal)"
    assert 0.5 < p <= 1.0


def test_ablated_siftom_prompt_shows_scene_and_actions_end_to_end_does_not():
    sc = get_scenario("kitchen-cereal-v0")
    with_ctx = lb.LLMChooser(WordMatchScorer(), with_context=True).prompt(sc, "pass me the silver")
    without = lb.LLMChooser(WordMatchScorer(), with_context=False).prompt(sc, "pass me the silver")
    assert "grab(human, milk, fridge)" in with_ctx and "kitchen_counter" in with_ctx
    assert "grab(human" not in without and 'Heard: "pass me the silver"' in without


def test_command_space_covers_counts_for_deliver_and_one_per_item_for_fetch():
    hh = get_scenario("household-table-v0/0")
    space = lb.command_space(hh)
    assert {str(c) for c in space} >= {"deliver(fork,1)", "deliver(fork,4)", "deliver(bowl,2)"}
    assert len(lb.command_space(get_scenario("kitchen-cereal-v0"))) == 42


def test_without_a_configured_backend_the_error_says_how_to_configure_one(monkeypatch):
    for var in ("SIFTOM_LLM_BASE_URL", "SIFTOM_LLM", "SIFTOM_LLM_BACKEND"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(lb, "_CHOOSERS", {})
    assert lb.configured_backend() is None
    with pytest.raises(BackendUnavailableError, match="SIFTOM_LLM_BASE_URL"):
        lb.chooser("llm-end-to-end")
    monkeypatch.setenv("SIFTOM_LLM", "llama")
    assert lb.configured_backend() == "llama"
