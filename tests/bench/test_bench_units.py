"""Literal parser, bootstrap CIs, scoring rules and dataset validation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.bench.evaluate import EvalOptions
from siftom.bench.literal import literal_command, parse_literal
from siftom.bench.metrics import bootstrap_ci, summarise_model
from siftom.bench.trials import is_correct, is_helpful
from siftom.errors import DatasetError, UnknownNameError
from siftom.people.stimuli import load_dataset
from siftom.scenarios.base import get_scenario

HOUSE = ("bowl", "fork", "knife", "mug", "plate", "spoon", "waterglass", "wineglass")


# -- literal parser ------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "cls", "count", "said"), [
    ("could you grab three forks", "fork", 3, True),
    ("bring me 2 plates", "plate", 2, True),
    ("we need four more wine glasses", "wineglass", 4, True),
    ("pass me the knife", "knife", 1, False),
    ("get me the rest of the spoons", "spoon", 1, False),
    ("i need a water glass please", "waterglass", 1, False),
    ("can you pass me two cups please", "mug", 2, True),
])
def test_parse_literal_reads_class_and_count(text: str, cls: str, count: int, said: bool) -> None:
    p = parse_literal(text, HOUSE)
    assert p is not None
    assert (p.obj_class, p.count, p.count_said) == (cls, count, said)


def test_parse_literal_prefers_longest_name_and_ignores_categories() -> None:
    assert parse_literal("three wine glasses", HOUSE).obj_class == "wineglass"  # type: ignore[union-attr]
    assert parse_literal("bring me the cutlery", HOUSE) is None
    assert parse_literal("pass me the serial", HOUSE) is None
    assert parse_literal("", HOUSE) is None


def test_literal_command_counts_bare_plurals_as_all_available_up_to_max() -> None:
    sc = get_scenario("household-table-v0/0")
    cmd = literal_command("get the bowls", sc, max_count=4)
    assert cmd is not None and cmd.obj_class == "bowl" and cmd.count == 4
    assert str(literal_command("a bowl", sc)) == "deliver(bowl,1)"
    assert literal_command("hmm", sc) is None


def test_literal_command_fetch_domain_ignores_counts() -> None:
    sc = get_scenario("kitchen-cereal-v0")
    assert str(literal_command("could you bring me two cereal", sc)) == "fetch(cereal)"


# -- scoring -------------------------------------------------------------------------------------

def test_correct_needs_class_and_count_except_for_fetch() -> None:
    assert is_correct("deliver(fork,3)", "deliver(fork,3)", "deliver")
    assert not is_correct("deliver(fork,2)", "deliver(fork,3)", "deliver")
    assert is_correct("fetch(milk,2)", "fetch(milk)", "fetch")
    assert not is_correct("none", "deliver(fork,3)", "deliver")
    assert is_helpful("deliver(fork,2)", {"fork": 3, "plate": 3})
    assert not is_helpful("deliver(mug,2)", {"fork": 3, "plate": 3})
    assert not is_helpful("none", {"fork": 3})


def test_summary_of_known_trials() -> None:
    trials = [
        {"command": "deliver(fork,3)", "correct": True, "helpful": True, "speedup": 0.4},
        {"command": "deliver(fork,2)", "correct": False, "helpful": True, "speedup": 0.2},
        {"command": "deliver(mug,2)", "correct": False, "helpful": False, "speedup": -0.1},
        {"command": "none", "correct": False, "helpful": False, "speedup": 0.0},
    ]
    s = summarise_model(trials, seed=1)
    assert s.accuracy == 0.25 and s.n == 4 and s.wrong == 3 and s.no_action == 1
    assert s.neg_speedup_share == 0.25
    assert s.helpful_error_share == pytest.approx(1 / 3)
    assert s.speedup == pytest.approx(0.125)


def test_unknown_model_suggests_names() -> None:
    with pytest.raises(UnknownNameError, match="siftom"):
        EvalOptions(models=("siftomm",))


# -- bootstrap -----------------------------------------------------------------------------------

@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-2, 2, allow_nan=False), min_size=1, max_size=40), st.integers(0, 1000))
def test_bootstrap_ci_contains_the_mean_and_stays_in_range(xs: list[float], seed: int) -> None:
    lo, hi = bootstrap_ci(xs, n_boot=200, seed=seed)
    assert min(xs) - 1e-9 <= lo <= hi <= max(xs) + 1e-9
    # the sample mean may sit outside a percentile CI only for tiny, skewed samples
    if len(xs) >= 10:
        assert lo - 0.5 <= float(np.mean(xs)) <= hi + 0.5


def test_bootstrap_ci_is_seeded_narrows_with_n_and_handles_edges() -> None:
    rng = np.random.default_rng(0)
    small = rng.random(20) < 0.7
    big = rng.random(2000) < 0.7
    assert bootstrap_ci(small, seed=5) == bootstrap_ci(small, seed=5)
    w_small = np.subtract(*bootstrap_ci(small)[::-1])
    w_big = np.subtract(*bootstrap_ci(big)[::-1])
    assert w_big < w_small
    lo, hi = bootstrap_ci(big)
    assert lo < 0.7 < hi
    assert bootstrap_ci([1.0]) == (1.0, 1.0)
    assert all(np.isnan(bootstrap_ci([])))


# -- malformed datasets --------------------------------------------------------------------------

def _line(**over: object) -> str:
    d = {"id": "a1", "scenario": "household-table-v0/0", "domain": "household-table-v0",
         "observed_actions": [], "audio": "a1.wav", "reference": "pass me the forks",
         "gold_goal": {"name": "g", "counts": {"fork": 3}}, "gold_command": "deliver(fork,3)", "speaker": "p1"}
    d.update(over)
    return json.dumps({k: v for k, v in d.items() if v is not ...})


@pytest.mark.parametrize(("content", "message"), [
    (None, "no manifest.jsonl"),
    ("", "lists no stimuli"),
    ("{not json\n", "not valid JSON"),
    (_line(gold_command=...) + "\n", "missing key"),
    (_line(gold_command="bring(fork)") + "\n", "gold_command"),
    (_line(snr_db=10) + "\n", "both 'noise' and 'snr_db'"),
    (_line() + "\n" + _line() + "\n", "appears twice"),
    (_line(audio="missing.wav") + "\n", "is missing"),
    (_line(id="a b") + "\n", "may use only"),
])
def test_malformed_dataset_raises_dataset_error(tmp_path: Path, content: str | None, message: str) -> None:
    (tmp_path / "a1.wav").write_bytes(b"RIFF")
    if content is not None:
        (tmp_path / "manifest.jsonl").write_text(content)
    with pytest.raises(DatasetError, match=message):
        load_dataset(tmp_path)


def test_missing_folder_says_how_to_build(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="siftom dataset build"):
        load_dataset(tmp_path / "nope")


def test_summary_counts_questions_confident_errors_and_missing_speedups() -> None:
    def trial(command: str, prob: float, correct: bool, speedup: float | None, **kw) -> dict:
        return {"command": command, "prob": prob, "correct": correct, "helpful": False, "speedup": speedup, **kw}

    trials = [
        trial("deliver(fork,3)", 0.9, False, -0.1, asked=True),  # confident and wrong
        trial("deliver(fork,2)", 0.95, True, 0.3, asked=True),
        trial("deliver(fork,2)", 0.5, False, 0.1, asked=False),  # wrong but not confident
        trial("none", 0.99, False, 0.0, asked=False),  # doing nothing is never confident-wrong
        trial("deliver(cup,1)", 0.2, False, None, asked=False,
              speedup_error="no plan for 1 cup (node_limit); the scenario may be unsolvable"),
    ]
    s = summarise_model(trials).to_json()
    assert s["questions_per_trial"] == pytest.approx(2 / 5)
    assert s["accuracy_after_answer"] == pytest.approx(1 / 2)
    assert s["confident_wrong_share"] == pytest.approx(1 / 5)
    assert s["no_speedup"] == 1 and s["n_speedup"] == 4
    assert s["no_speedup_reasons"] == {"planner budget exhausted (node_limit)": 1}
    assert s["neg_speedup_share"] == pytest.approx(1 / 4)
    plain = summarise_model([{k: v for k, v in t.items() if k != "asked"} for t in trials]).to_json()
    assert plain["accuracy_after_answer"] is None and plain["questions_per_trial"] == 0


def test_decision_models_are_every_rule_on_every_likelihood() -> None:
    from siftom.assist.decide import RULES
    from siftom.bench.models import decision_models

    DECISION_MODELS = decision_models()
    LIKELIHOOD_TAGS, RULE_TAGS = ("acoustic", "phonetic"), ("expected-benefit", "ask-or-act", "teammate")
    from siftom.likelihood.registry import LIKELIHOODS

    assert set(DECISION_MODELS.values()) == {(lk, r) for lk in LIKELIHOOD_TAGS for r in RULE_TAGS}
    assert DECISION_MODELS["siftom-ask"] == ("acoustic", "ask-or-act")
    assert DECISION_MODELS["siftom-phonetic-eb"] == ("phonetic", "expected-benefit")
    assert set(RULE_TAGS) | {"map"} == set(RULES.names())
    assert set(LIKELIHOOD_TAGS) <= set(LIKELIHOODS.names())


def test_regret_is_the_oracle_speedup_minus_the_model_speedup() -> None:
    from siftom.bench.metrics import oracle_summary, regret

    rows = [{"gold_command": "fetch(milk)", "oracle": {"command": "fetch(milk)", "speedup": 0.5},
             "models": {"m": {"speedup": 0.5}}},
            {"gold_command": "deliver(plate,3)", "oracle": {"command": "deliver(plate,2)", "speedup": 0.4},
             "models": {"m": {"speedup": -0.1}}},
            {"gold_command": "fetch(milk)", "oracle": {"command": "none", "speedup": None},
             "models": {"m": {"speedup": 0.2}}}]
    r, ci, n = regret(rows, "m")
    assert n == 2 and r == pytest.approx(0.25) and ci[0] <= r <= ci[1]
    o = oracle_summary(rows)
    assert o is not None and o.speedup == pytest.approx(0.45) and o.gold_is_best == pytest.approx(0.5)


def test_answer_reliability_follows_the_measured_table() -> None:
    from siftom.assist.questions import KINDS
    from siftom.bench.decisions import ANSWER_RELIABILITY, answer_reliability, reliability_table

    assert set(ANSWER_RELIABILITY) == set(KINDS)
    for kind, rows in ANSWER_RELIABILITY.items():
        table = dict(rows)
        assert answer_reliability(None, kind) == table[float("inf")]  # clean speech
        assert answer_reliability(5.0, kind) == table[5.0] and answer_reliability(0.0, kind) == table[5.0]
        assert answer_reliability(7.5, kind) == pytest.approx((table[5.0] + table[10.0]) / 2)
        assert all(0 <= r <= 1 for r in table.values())
    rows = [{"snr_db": 5.0, "models": {"siftom-ask": {"asked": True, "answer_cell_ok": ok}}} for ok in (True, False)]
    rows.append({"snr_db": None, "models": {"siftom-ask": {"asked": False}}})
    assert reliability_table(rows) == [{"snr_db": 5.0, "n": 2, "heard": 0.5}]


def test_answers_are_said_from_the_cell_and_heard_by_the_first_hypothesis_naming_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from types import SimpleNamespace

    from siftom.assist.questions import count_question
    from siftom.bench import answers
    from siftom.observation import Hypothesis

    q = count_question("spoon", [f"deliver(spoon,{k})" for k in range(1, 5)])
    said = answers.answer_phrase(q, 2, "household-table-v0/3#s1")
    assert said in q.answers[2] and said == answers.answer_phrase(q, 2, "household-table-v0/3#s1")
    monkeypatch.setattr(answers, "answer_audio", lambda *a, **k: np.zeros(160, dtype=np.float32))
    heard_grammar = []

    def listen(x: np.ndarray, grammar: tuple[str, ...]) -> SimpleNamespace:
        heard_grammar.append(grammar)
        return SimpleNamespace(text="please", nbest=(Hypothesis("please", 0.0), Hypothesis("three please", -1.0)))

    stim = SimpleNamespace(id="x")
    h = answers.ask_and_hear(q, 2, stim, ".", listen)
    assert heard_grammar == [q.grammar()]  # the recogniser listens for this question's answers
    assert h.heard_cell == 2 and h.answer_heard == "three please"
    assert set(answers.answer_reliabilities(5.0)) == {"confirm", "choose", "count"}


def test_a_plugin_registers_a_kind_of_evaluator_model_without_editing_siftom(monkeypatch):
    from siftom.bench.choosers import Trial, TrialHeard, choose
    from siftom.bench.models import (
        EVAL_KINDS,
        EVAL_MODELS,
        EvalOptions,
        eval_model,
        register_eval_model,
    )
    from siftom.errors import SiftomError
    from siftom.people.stimuli import Stimulus, scenario_for

    for registry in (EVAL_KINDS, EVAL_MODELS):  # registered for this test only
        monkeypatch.setattr(registry, "_entries", dict(registry.entries()))
    EVAL_KINDS.register("first-class", "support.evalkind:choose_first", summary="the first class, always")
    register_eval_model("first-class-baseline", "a test plug-in", kind="first-class", heard="none")
    opts = EvalOptions(models=("first-class-baseline",))
    s = Stimulus(id="t", scenario="kitchen-cereal-v0", domain="kitchen-v0", observed_actions=(), audio="t.wav",
                 reference="", gold_goal={}, gold_command="fetch(cereal)", speaker="s1", voice="flite-slt")
    sc = scenario_for(s)
    heard = TrialHeard(opts, (), Path("t.wav"), {"text": "", "nbest": []})
    assert choose(Trial(eval_model("first-class-baseline"), s, sc, "k", heard, ".")) == (
        f"fetch({sorted(sc.world.classes)[0]})", 0.5, {})
    register_eval_model("no-such-kind-model", kind="no-such-kind")
    with pytest.raises(SiftomError, match="evaluator kind"):  # an unknown kind names the registered ones
        EvalOptions(models=("no-such-kind-model",))
