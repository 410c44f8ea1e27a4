"""Open-vocabulary recognition: the background-word LM, the sound-alike filter, the dual engine."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from siftom.likelihood.asr import distinct_words
from siftom.observation import Hypothesis
from siftom.speech.asr.dual import mix_nbest
from siftom.speech.asr.pocketsphinx import add_background_words, build_arpa

FOODS = ("cereal", "milk", "sugar", "coffee", "tea", "pasta", "flour", "bread")
needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")


def _unigrams(arpa: str) -> dict[str, float]:
    lines = arpa.splitlines()
    start = lines.index("\\1-grams:")
    out = {}
    for line in lines[start + 1:]:
        if line.startswith("\\"):
            break
        parts = line.split()
        if len(parts) >= 2:
            out[parts[1]] = float(parts[0])
    return out


def test_background_words_get_their_mass_and_the_phrasings_unigrams_shrink():
    arpa = build_arpa(["pass me the milk", "bring me the tea", "i need the cereal"])
    before = _unigrams(arpa)
    bg = [("weather", -2.0), ("yesterday", -3.0), ("milk", -2.5)]  # milk is already known
    after = _unigrams(add_background_words(arpa, bg, 0.2))

    def mass(uni: dict[str, float], keep: set[str] | None = None) -> float:
        return sum(10 ** lp for w, lp in uni.items() if lp > -99 and (keep is None or w in keep))

    assert set(after) == set(before) | {"weather", "yesterday"}
    assert mass(after, {"weather", "yesterday"}) == pytest.approx(0.2, abs=1e-3)
    # the background keeps its own proportions (10:1) and the phrasings' unigrams shrink by 1 - w
    assert after["weather"] - after["yesterday"] == pytest.approx(1.0, abs=1e-3)
    assert after["milk"] == pytest.approx(before["milk"] + math.log10(0.8), abs=1e-3)
    # (ArpaBoLM's discounting leaves the phrasings' unigrams short of 1; the mix keeps that)
    assert mass(after) == pytest.approx(0.8 * mass(before) + 0.2, abs=2e-3)


def test_background_words_that_sound_like_meaning_words_are_left_out():
    phrase_words = {"pass", "me", "the", "milk", "tea", "cereal", "three", "forks"}
    cands = [("mill", -3.0), ("tee", -3.0), ("fork", -3.0), ("tree", -3.0), ("weather", -3.0),
             ("yesterday", -3.0), ("somebody", -3.0)]
    kept = [w for w, _ in distinct_words(cands, phrase_words)]
    assert kept == ["weather", "yesterday", "somebody"]


def test_mix_nbest_is_an_equal_mixture_of_each_lists_posteriors():
    a = [Hypothesis("pass me the milk", -100.0), Hypothesis("pass me the tea", -102.0)]
    b = [Hypothesis("um could you get the milk", -300.0), Hypothesis("pass me the milk", -301.0)]
    out = mix_nbest([a, b], 5)
    pa = np.exp([0.0, -2.0]) / np.exp([0.0, -2.0]).sum()
    pb = np.exp([0.0, -1.0]) / np.exp([0.0, -1.0]).sum()
    expect = {"pass me the milk": 0.5 * pa[0] + 0.5 * pb[1], "pass me the tea": 0.5 * pa[1],
              "um could you get the milk": 0.5 * pb[0]}
    assert [h.text for h in out] == sorted(expect, key=lambda t: -expect[t])
    for h in out:
        assert h.score == pytest.approx(math.log(expect[h.text]))
    assert sum(math.exp(h.score) for h in out) == pytest.approx(1.0)
    assert [h.text for h in mix_nbest([a, b], 1)] == ["pass me the milk"]
    assert mix_nbest([[], []], 3) == ()
    assert [h.text for h in mix_nbest([a, []], 3)] == ["pass me the milk", "pass me the tea"]


@pytest.mark.slow
@needs_flite
def test_open_engines_hear_words_outside_the_phrasings_as_other_words():
    """A request the phrasings do not contain: the open engine keeps the object and does not make
    object names out of the other words; the dual engine's list holds such a hypothesis (its 1-best
    may be the phrasings LM's, which forces the other words onto object names: "... the pasta")."""
    from siftom.speech.asr.base import get_engine
    from siftom.speech.tts import synthesize

    vocab = [f"{c} the {f}" for f in FOODS for c in ("pass me", "bring me", "i need")]
    clip = synthesize("i think we are out of milk so could you look for some", "flite-slt")
    others = set(FOODS) - {"milk"}
    for name in ("pocketsphinx-open", "pocketsphinx-dual"):
        tr = get_engine(name, vocabulary=vocab).transcribe(clip, nbest=5)
        assert tr.engine == name
        assert 1 <= len(tr.nbest) <= 5
        clean = [h.text for h in tr.nbest if "milk" in h.text.split() and not set(h.text.split()) & others]
        if name == "pocketsphinx-open":
            assert tr.text in clean, (name, tr.text)
        assert clean, (name, [h.text for h in tr.nbest])


def test_boost_multiplies_only_the_given_words_unigrams():
    from siftom.likelihood.asr import meaning_words
    from siftom.speech.asr.pocketsphinx import boost_unigrams

    arpa = build_arpa(["pass me the milk", "bring me two cups of tea"])
    before = _unigrams(arpa)
    words = meaning_words(["pass me the milk", "bring me two cups of tea"])
    assert words == {"milk", "two", "cups", "tea"}  # filler words (pass, me, the, bring, of) are not boosted
    after = _unigrams(boost_unigrams(arpa, words, 4.0))
    for w, lp in before.items():
        want = lp + math.log10(4.0) if w in words and lp > -99 else lp
        assert after[w] == pytest.approx(want, abs=1e-4), w
    assert boost_unigrams(arpa, words, 1.0) == arpa
