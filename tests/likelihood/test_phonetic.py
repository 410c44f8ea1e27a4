import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.errors import ObservationError
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.likelihood.editdistance import (
    PhonemeTrie,
    batch_edit_distance,
    edit_distance,
    encode,
    trie_edit_distance,
)
from siftom.likelihood.lexicon import HOUSEHOLD_CLASSES, KITCHEN_ITEMS
from siftom.likelihood.phonemes import (
    PHONEMES,
    indel_cost,
    ipa_to_arpabet,
    letters_to_arpabet,
    normalize_text,
    substitution_cost,
    text_phonemes,
    word_phonemes,
)
from siftom.likelihood.phonetic import PhoneticLikelihood
from siftom.world.commands import RobotCommand

KITCHEN = [RobotCommand("fetch", c) for c in KITCHEN_ITEMS]
HOUSEHOLD = [RobotCommand("deliver", c, n) for c in HOUSEHOLD_CLASSES for n in range(1, 5)]

phones = st.lists(st.sampled_from(PHONEMES), max_size=8)


@pytest.fixture(scope="module")
def lik():
    return PhoneticLikelihood()


def ranking(lik, text, commands):
    lp = lik.log_prob(Instruction.from_text(text), commands).log_probs
    return [commands[i] for i in np.argsort(-lp, kind="stable")]


# -- the edit distance ----------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(x=phones, y=phones)
def test_edit_distance_is_a_symmetric_nonnegative_distance(x, y):
    assert edit_distance(x, x) == 0
    d = edit_distance(x, y)
    assert d >= 0
    assert d == pytest.approx(edit_distance(y, x), abs=1e-9)
    if x != y:
        assert d > 0


@settings(max_examples=100, deadline=None)
@given(x=phones, y=phones, z=phones)
def test_edit_distance_obeys_the_triangle_inequality(x, y, z):
    assert edit_distance(x, z) <= edit_distance(x, y) + edit_distance(y, z) + 1e-6


@settings(max_examples=50, deadline=None)
@given(said=st.lists(phones, min_size=1, max_size=5), heard=st.lists(phones, min_size=1, max_size=4))
def test_vectorised_distances_match_the_reference(said, heard):
    seqs = [(encode(s), np.array([indel_cost(p) for p in s], dtype=np.float32)) for s in said]
    ins = [np.array([indel_cost(p) * 0.5 for p in h], dtype=np.float32) for h in heard]
    sub = [np.full(len(h), 0.25, dtype=np.float32) for h in heard]
    expected = np.array([[edit_distance(s, h, [indel_cost(p) * 0.5 for p in h]) if h else
                          sum(indel_cost(p) for p in s) for h in heard] for s in said])
    nonempty = [k for k, h in enumerate(heard) if h]
    if nonempty:
        triples = [(encode(heard[k]), ins[k], np.zeros(len(heard[k]), np.float32)) for k in nonempty]
        got = trie_edit_distance(PhonemeTrie.build(seqs), triples)
        np.testing.assert_allclose(got, expected[:, nonempty], atol=1e-4)
        # batch version with a substitution penalty, checked against a penalised reference
        from siftom.likelihood.editdistance import _pad

        s_ids, s_del = _pad([s for s, _ in seqs], [c for _, c in seqs])
        h_ids, h_ins = _pad([encode(heard[k]) for k in nonempty], [ins[k] for k in nonempty])
        _, h_sub = _pad([encode(heard[k]) for k in nonempty], [sub[k] for k in nonempty])
        got_b = batch_edit_distance(s_ids, s_del, h_ids, h_ins, np.zeros_like(h_sub))
        np.testing.assert_allclose(got_b, expected[:, nonempty], atol=1e-4)


def test_similar_phonemes_are_cheaper_to_confuse():
    assert substitution_cost("P", "B") < substitution_cost("P", "S") < substitution_cost("P", "IY")
    assert substitution_cost("IY", "IH") < substitution_cost("IY", "K")
    assert substitution_cost("M", "N") < substitution_cost("M", "S")
    assert substitution_cost("TH", "T") < substitution_cost("TH", "G")


# -- words to phonemes ----------------------------------------------------------------------


def test_pronunciations_come_from_cmudict_with_fallbacks():
    assert word_phonemes("milk") == ("M", "IH", "L", "K")
    assert word_phonemes("wineglass")[:3] == ("W", "AY", "N")  # compound split
    assert ipa_to_arpabet("wˈaɪŋɡlas") == ("W", "AY", "NG", "G", "L", "AE", "S")
    assert letters_to_arpabet("shock") == ("SH", "AA", "K")
    assert len(word_phonemes("zorbulated")) >= 6  # not in CMUdict: espeak-ng or letters
    assert all(p in PHONEMES for p in text_phonemes("blorptastic yoghurt"))


def test_text_normalisation_handles_digits_and_asr_markup():
    assert normalize_text("Bring me 3 <sil> forks(2), please! [NOISE]") == [
        "bring", "me", "three", "forks", "please"]


# -- required behaviour ---------------------------------------------------------------------


def test_is_an_instruction_likelihood(lik):
    assert isinstance(lik, InstructionLikelihood)
    out = lik.log_prob(Instruction.from_text("pass me the milk"), KITCHEN).log_probs
    assert out.shape == (len(KITCHEN),) and np.all(np.isfinite(out))


@pytest.mark.parametrize("text", ["pass me the silver", "can you pass me the silver"])
def test_silver_puts_cereal_in_the_top_three_on_words_alone(lik, text):
    assert RobotCommand("fetch", "cereal") in ranking(lik, text, KITCHEN)[:3]


@pytest.mark.parametrize("text", ["pass me the cereal", "pass me the serial", "can you pass me the cereal please"])
def test_cereal_ranks_first_when_heard(lik, text):
    assert ranking(lik, text, KITCHEN)[0] == RobotCommand("fetch", "cereal")


@pytest.mark.parametrize("text", ["bring me three forks", "bring me 3 forks", "bring me tree forks"])
def test_count_is_recovered(lik, text):
    assert ranking(lik, text, HOUSEHOLD)[0] == RobotCommand("deliver", "fork", 3)


@pytest.mark.parametrize("text", ["can you pass me the mail", "pass me the meal"])
def test_milk_confusions_rank_milk_high(lik, text):
    assert RobotCommand("fetch", "milk") in ranking(lik, text, KITCHEN)[:2]


def test_flower_means_flour(lik):
    assert ranking(lik, "could you grab the flower", KITCHEN)[0] == RobotCommand("fetch", "flour")


def test_synonyms_and_categories(lik):
    assert ranking(lik, "we still need three wine glasses", HOUSEHOLD)[0] == RobotCommand("deliver", "wineglass", 3)
    top3 = {c.obj_class for c in ranking(lik, "pass me the cutlery", [RobotCommand("deliver", c, 1) for c in HOUSEHOLD_CLASSES])[:3]}
    assert top3 == {"fork", "knife", "spoon"}


def test_without_a_count_all_counts_are_nearly_equal(lik):
    lp = lik.log_prob(Instruction.from_text("bring me the forks"),
                      [RobotCommand("deliver", "fork", n) for n in (2, 3, 4)]).log_probs
    assert np.ptp(lp) < 0.2


def test_nbest_weights_follow_asr_scores():
    lik = PhoneticLikelihood(asr_temperature=1.0)
    cmds = [RobotCommand("fetch", "milk"), RobotCommand("fetch", "flour")]
    sure_milk = Instruction.from_nbest([("pass me the milk", 0.0), ("pass me the flour", -50.0)])
    unsure = Instruction.from_nbest([("pass me the milk", 0.0), ("pass me the flour", -1.0)])
    a, b = lik.log_prob(sure_milk, cmds).log_probs, lik.log_prob(unsure, cmds).log_probs
    assert a[0] - a[1] > b[0] - b[1] > 0


def test_repeated_calls_are_consistent_and_cached(lik):
    ins = Instruction.from_nbest([("pass me the silver", 0.0), ("pass me the cereal", -3.0)])
    first = lik.log_prob(ins, KITCHEN).log_probs
    fresh = PhoneticLikelihood().log_prob(ins, KITCHEN).log_probs
    np.testing.assert_allclose(first, lik.log_prob(ins, KITCHEN).log_probs)
    np.testing.assert_allclose(first, fresh, atol=1e-9)
    # a subset of the commands gives the same scores for them
    np.testing.assert_allclose(lik.log_prob(ins, KITCHEN[5:9]).log_probs, first[5:9], atol=1e-9)


def test_explain_lists_phrasings_best_first(lik):
    rows = lik.explain(Instruction.from_text("bring me three forks"), RobotCommand("deliver", "fork", 3))
    assert rows[0][0] == "three forks"
    assert [r[1] for r in rows] == sorted((r[1] for r in rows), reverse=True)


def test_inputs_are_validated():
    with pytest.raises(ObservationError, match="lam"):
        PhoneticLikelihood(lam=0)
    from pathlib import Path

    with pytest.raises(ObservationError, match="transcribe"):
        PhoneticLikelihood().log_prob(Instruction(audio=Path("x.wav")), KITCHEN)
    assert PhoneticLikelihood().log_prob(Instruction.from_text("milk"), []).log_probs.shape == (0,)


def test_empty_hypothesis_is_uninformative(lik):
    out = lik.log_prob(Instruction.from_nbest([("<sil>", 0.0)]), KITCHEN).log_probs
    assert np.ptp(out) < 1e-6


def test_fast_enough_for_inference(lik):
    cmds = [RobotCommand("deliver", c, n) for c in (*KITCHEN_ITEMS, *HOUSEHOLD_CLASSES) for n in (1, 2, 3, 4)][:200]
    ins = Instruction.from_nbest([(f"can you pass me the {w}", -k) for k, w in enumerate(
        ["silver", "cereal", "serial", "real", "milk", "mail", "meal", "flower", "forks", "four"])])
    lik.log_prob(ins, cmds)
    t = time.perf_counter()
    for _ in range(20):
        lik.log_prob(ins, cmds)
    assert (time.perf_counter() - t) / 20 < 0.02  # generous: ~0.4 ms measured on 2 cores


def test_a_scene_biased_recognisers_names_speak_softly():
    from dataclasses import replace

    cmds = [RobotCommand("fetch", "cup"), RobotCommand("fetch", "dressing")]
    heard = Instruction.from_text("would you grab cup")
    typed = PhoneticLikelihood().log_prob(heard, cmds).log_probs
    biased = PhoneticLikelihood().log_prob(replace(heard, scene_words=True), cmds).log_probs
    assert typed[0] - typed[1] > biased[0] - biased[1] > 0  # still the cup, by less
