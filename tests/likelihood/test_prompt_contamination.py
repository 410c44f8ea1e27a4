"""The LLM prompts must not contain benchmark content (objects, utterances, the Figure 2 story)."""

import re
from functools import cache

import pytest

from siftom.bench import llm_baselines
from siftom.likelihood.lexicon import default_lexicon
from siftom.likelihood.llm import FEW_SHOT, HEADER, SOUNDS_NOTE, build_prefix
from siftom.likelihood.phrasing import FILLER_WORDS, NUMBER_WORDS, command_vocabulary
from siftom.scenarios.base import get_scenario, scenario_ids
from siftom.world.domains.kitchen import library

# The paper's stories: Figure 2 ("can you pass me the cereal", heard "silver"; milk and a bowl
# taken; cereal, oatmeal or sugar) and Figure 1 (tomato heard as potato).
STORY_WORDS = {"cereal", "silver", "milk", "bowl", "bowls", "oatmeal", "sugar", "tomato", "potato",
               "tomatoes", "potatoes"}
# Words every request shares: the command syntax, function words, numbers.
STRUCTURE = {"pass", "deliver", "robot", "human", "table", "me", "the", "a", "an", "i", "we", "you",
             "could", "can", "need", "still", "get", "grab", "hand", "please", "to", "for", "tree",
             "her", "bring", "some"} | set(FILLER_WORDS) | set(NUMBER_WORDS)


def _words(text: str) -> set[str]:
    return set(re.findall(r"[a-z]+", text.lower()))


@cache
def benchmark_object_words() -> frozenset[str]:
    """Every word that names an object of a registered scenario or either domain's vocabulary."""
    lex = default_lexicon()
    classes: set[str] = set(lex.classes) | set(library()["items"])
    verbs: set[str] = set()
    for sid in scenario_ids():
        sc = get_scenario(sid)
        classes |= set(sc.world.classes)
        verbs.add(sc.verb)
    words: set[str] = set()
    for c in classes:
        words |= _words(c.replace("_", " "))
        if c in lex:
            for n in lex.entry(c).names:
                words |= _words(n.singular) | _words(n.plural)
    for cat in lex.categories:
        words |= _words(cat.word)
    for item in library()["items"].values():
        words |= _words(item.get("spoken", ""))
    return frozenset(words - STRUCTURE)


@cache
def benchmark_sentences() -> frozenset[str]:
    classes = sorted({c for sid in scenario_ids() for c in get_scenario(sid).world.classes})
    return frozenset(s for verb in ("fetch", "deliver") for s in command_vocabulary(classes, verb))


def test_the_reference_word_lists_are_not_empty():
    words = benchmark_object_words()
    assert {"cereal", "fork", "forks", "wine", "knives", "cutlery", "flour"} <= words
    assert len(benchmark_sentences()) > 100


@pytest.mark.parametrize("command, heard", FEW_SHOT)
def test_few_shot_examples_use_no_benchmark_object_or_story(command, heard):
    obj_words = _words(command.split(",")[2] if command.startswith("deliver") else command.split(",")[-1])
    forbidden = benchmark_object_words() | STORY_WORDS
    assert not obj_words & forbidden, f"example object {command!r} is a benchmark object"
    assert not (_words(heard) & forbidden), f"utterance {heard!r} uses a benchmark word"
    assert heard not in benchmark_sentences()


def test_prompts_do_not_contain_the_figure_2_pair():
    for text in (build_prefix(), build_prefix(prompt="sounds"), HEADER, SOUNDS_NOTE,
                 llm_baselines.HEADER, llm_baselines.CHAT_SYSTEM):
        assert "silver" not in text and "cereal" not in text
    # and a contaminated example would be caught
    assert _words("pass me the silver") & STORY_WORDS
    assert _words("bring me tree forks") & benchmark_object_words()
