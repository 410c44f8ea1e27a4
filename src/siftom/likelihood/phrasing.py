"""How a person would say a robot command: P(u | pi_r) over phrasings u.

A phrasing is a carrier ("could you grab ___", "we still need ___") around a noun phrase
("three forks", "the cereal", "the cutlery"). Carriers and noun phrases are chosen
independently, each from a small weighted list that mirrors how people ask at a table:

* styles (carrier prior): direct 0.45 ("bring me", "pass me", "get"), polite 0.35 ("could you
  grab", "can you pass me ... please"), indirect 0.20 ("we still need", "I need", "get me the
  rest of the");
* noun phrases: for two or more items the number is said 60 % of the time ("three forks"),
  else "the forks"; one item is "the fork" / "a fork" / "one fork"; mass nouns take no
  number ("the milk", "some milk");
* names: the canonical name gets 0.75 of the mass, synonyms share 0.25 ("glass", "cup"),
  and a category word that covers the class ("cutlery", "dishes") takes 0.1 off the top.

The verb of the command (deliver/fetch) does not change the words: both bring items to the
human. Log priors are normalised per command (their logsumexp is 0).

The words that carry no information about the command (carrier verbs, articles, "please") are
listed in :data:`FILLER_WORDS`; the noisy channel in ``phonetic.py`` aligns the remaining
*content* words, so ``Phrasing.content`` is what it scores.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from siftom.errors import CommandParseError, unknown_name
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.numbers import (
    NUMBER_WORDS as NUMBER_WORDS,  # re-exported: the words of counts
)
from siftom.likelihood.numbers import number_word as number_word
from siftom.world.commands import MAX_COUNT, RobotCommand

# Carriers per style: (template, weight within style). "{np}" is the noun phrase; templates
# whose noun phrase must be a bare plural without number use "{pl}".
CARRIERS: dict[str, tuple[tuple[str, float], ...]] = {
    "direct": (
        ("bring me {np}", 3.0), ("pass me {np}", 3.0), ("get {np}", 1.5), ("get me {np}", 2.0),
        ("grab {np}", 1.5), ("hand me {np}", 1.5), ("give me {np}", 1.0), ("{np} please", 1.0),
        ("bring {np} here", 0.5), ("fetch {np}", 0.5),
    ),
    "polite": (
        ("could you grab {np}", 2.0), ("can you pass me {np} please", 2.0),
        ("could you bring me {np}", 2.0), ("can you get {np}", 1.5),
        ("can you pass me {np}", 2.0), ("would you pass me {np}", 1.0),
        ("please bring me {np}", 1.0), ("could you hand me {np} please", 1.0),
    ),
    "indirect": (
        ("we still need {np}", 2.0), ("i need {np}", 2.0), ("we need {np}", 1.5),
        ("get me the rest of the {pl}", 1.0), ("i'm missing {np}", 0.5),
        ("i still need {np}", 1.0),
    ),
}
STYLE_WEIGHTS = {"direct": 0.45, "polite": 0.35, "indirect": 0.20}
# "category" is not a carrier style but a naming choice; sample_phrasing accepts it too.
STYLES = (*STYLE_WEIGHTS, "category")

CANONICAL_WEIGHT = 0.75
CATEGORY_WEIGHT = 0.10
COUNT_SAID = 0.60

# Words that do not distinguish one command from another. Everything else is content.
FILLER_WORDS = frozenset(
    ["a", "an", "the", "some", "any", "of", "to", "for", "and", "or", "my", "our", "your", "his", "her", "their", "this", "that", "these", "those", "them", "it", "me", "us", "i", "we", "you", "i'm", "we're", "you're", "i'd", "let's", "bring", "get", "grab", "pass", "hand", "give", "fetch", "take", "put", "pick", "up", "over", "here", "there", "please", "thanks", "thank", "could", "can", "would", "will", "you'd", "do", "just", "also", "need", "needs", "want", "still", "missing", "more", "another", "rest", "all", "go", "find", "set", "on", "at", "in", "with", "from", "out", "yes", "okay", "ok", "hey", "um", "uh", "so", "now", "again"]
)


@dataclass(frozen=True)
class Phrasing:
    """One way to say a command.

    Attributes:
        text: the sentence, lowercase words.
        log_prior: log P(u | pi_r), normalised over the command's phrasings.
        style: "direct", "polite" or "indirect".
        content: the words that carry the command (``text`` without filler words).
        category: True when the class is named by a category word ("the cutlery").
    """

    text: str
    log_prior: float
    style: str
    content: str
    category: bool = False


def indefinite_article(phrase: str) -> str:
    """"an" before a vowel sound ("an onion", "an egg"), else "a" ("a utensil", "a fork").

    Decided by the first phoneme of the first word (CMUdict, then espeak-ng), not its spelling.
    """
    from siftom.likelihood.phonemes import VOWELS, word_phonemes

    words = phrase.split()
    phones = word_phonemes(words[0].lower()) if words else ()
    return "an" if phones and phones[0] in VOWELS else "a"


def content_words(text: str) -> str:
    """Drop filler words: ``"could you grab three forks"`` -> ``"three forks"``."""
    return " ".join(w for w in text.split() if w not in FILLER_WORDS)


def _noun_phrases(command: RobotCommand, lexicon: Lexicon) -> list[tuple[str, str, float, bool]]:
    """(noun phrase, bare plural for "rest of the" carriers or '', weight, is_category)."""
    entry = lexicon.entry(command.obj_class)
    n = command.count
    num = number_word(n)
    cats = lexicon.categories_of(command.obj_class)
    name_mass = 1.0 - (CATEGORY_WEIGHT if cats else 0.0)
    names = entry.names
    if len(names) == 1:
        name_weights = [1.0]
    else:
        name_weights = [CANONICAL_WEIGHT] + [(1 - CANONICAL_WEIGHT) / (len(names) - 1)] * (len(names) - 1)
    out: list[tuple[str, str, float, bool]] = []
    for name, w in zip(names, name_weights, strict=True):
        w *= name_mass
        if entry.mass:
            if n == 1:
                out += [(f"the {name.singular}", "", 0.6 * w, False),
                        (f"some {name.singular}", "", 0.3 * w, False),
                        (name.singular, "", 0.1 * w, False)]
            else:
                out += [(f"{num} {name.plural}", "", COUNT_SAID * w, False),
                        (f"the {name.singular}", "", (1 - COUNT_SAID) * w, False)]
        elif n == 1:
            out += [(f"the {name.singular}", "", 0.4 * w, False),
                    (f"{indefinite_article(name.singular)} {name.singular}", "", 0.35 * w, False),
                    (f"one {name.singular}", "", 0.15 * w, False),
                    (f"another {name.singular}", "", 0.1 * w, False)]
        else:
            out += [(f"{num} {name.plural}", name.plural, COUNT_SAID * 0.8 * w, False),
                    (f"{num} more {name.plural}", name.plural, COUNT_SAID * 0.2 * w, False),
                    (f"the {name.plural}", name.plural, (1 - COUNT_SAID) * w, False)]
    if cats:
        cw = CATEGORY_WEIGHT / len(cats)
        for c in cats:
            if c.countable and n > 1:
                out += [(f"{num} {c.word}", c.word, 0.5 * cw, True),
                        (f"the {c.word}", c.word, 0.5 * cw, True)]
            else:
                out.append((f"the {c.word}", c.word if c.countable else "", cw, True))
    return out


@lru_cache(maxsize=65536)
def _phrasings_cached(command: RobotCommand, lexicon: Lexicon) -> tuple[Phrasing, ...]:
    nps = _noun_phrases(command, lexicon)
    # Keyed by text: a synonym and a category word may produce the same sentence.
    raw: dict[str, float] = defaultdict(float)
    meta: dict[str, tuple[str, bool]] = {}
    for style, sw in STYLE_WEIGHTS.items():
        carriers = CARRIERS[style]
        total = sum(w for _, w in carriers)
        for template, cw in carriers:
            for np_text, bare_plural, nw, is_cat in nps:
                if "{pl}" in template:
                    if not bare_plural or command.count == 1:
                        continue
                    text = template.format(pl=bare_plural)
                else:
                    text = template.format(np=np_text)
                raw[text] += sw * (cw / total) * nw
                meta.setdefault(text, (style, is_cat))
    z = sum(raw.values())
    return tuple(
        Phrasing(text, math.log(w / z), meta[text][0], content_words(text), meta[text][1])
        for text, w in raw.items()
    )


def phrasing_details(command: RobotCommand, lexicon: Lexicon | None = None) -> tuple[Phrasing, ...]:
    """All phrasings of a command with style and content words; deterministic order."""
    return _phrasings_cached(command, lexicon or default_lexicon())


def phrasings(command: RobotCommand, lexicon: Lexicon | None = None) -> list[tuple[str, float]]:
    """(text, log prior) for each way a person might say ``command``; logsumexp of priors is 0."""
    return [(p.text, p.log_prior) for p in phrasing_details(command, lexicon)]


@lru_cache(maxsize=65536)
def _content_prior_cached(command: RobotCommand, lexicon: Lexicon) -> tuple[tuple[str, float], ...]:
    acc: dict[str, float] = defaultdict(float)
    for p in _phrasings_cached(command, lexicon):
        acc[p.content] += math.exp(p.log_prior)
    return tuple((c, math.log(w)) for c, w in acc.items())


def content_prior(command: RobotCommand, lexicon: Lexicon | None = None) -> tuple[tuple[str, float], ...]:
    """P(content | command): phrasings grouped by their content words, log priors summing to 1."""
    return _content_prior_cached(command, lexicon or default_lexicon())


def phrasing_styles(command: RobotCommand, lexicon: Lexicon | None = None) -> tuple[str, ...]:
    """Styles :func:`sample_phrasing` can produce for this command."""
    ph = phrasing_details(command, lexicon)
    styles = [s for s in STYLE_WEIGHTS if any(p.style == s for p in ph)]
    if any(p.category for p in ph):
        styles.append("category")
    return tuple(styles)


def sample_phrasing(
    command: RobotCommand,
    lexicon: Lexicon | None,
    rng: np.random.Generator,
    style: str | None = None,
) -> str:
    """Draw a phrasing from P(u | command), optionally restricted to one style.

    Args:
        command: the robot command to say.
        lexicon: names of classes (default: :func:`default_lexicon`).
        rng: a seeded generator, so datasets are reproducible.
        style: "direct", "polite", "indirect" or "category" (named by a category word);
            None draws from the full distribution.

    Raises:
        UnknownNameError: the style is not one of :data:`STYLES`.
        CommandParseError: the command has no phrasing in that style (e.g. "category" for a
            class no category word covers); see :func:`phrasing_styles`.
    """
    if style is not None and style not in STYLES:
        raise unknown_name("phrasing style", style, STYLES)
    ph: Sequence[Phrasing] = phrasing_details(command, lexicon)
    if style == "category":
        ph = [p for p in ph if p.category]
    elif style is not None:
        ph = [p for p in ph if p.style == style and not p.category]
    if not ph:
        raise CommandParseError(
            f"{command} has no phrasing in style {style!r}; "
            f"available: {', '.join(phrasing_styles(command, lexicon))}"
        )
    logp = np.array([p.log_prior for p in ph])
    prob = np.exp(logp - logp.max())
    prob /= prob.sum()
    return ph[int(rng.choice(len(ph), p=prob))].text


def command_vocabulary(classes: Sequence[str], verb: str, max_count: int = MAX_COUNT,
                       lexicon: Lexicon | None = None) -> list[str]:
    """Every phrasing of every command over ``classes`` (counts 1..max_count for ``deliver``),
    in order, without repeats: the sentences a scene-biased ASR language model is built from."""
    lex = lexicon or default_lexicon()
    counts = range(1, max_count + 1) if verb == "deliver" else (1,)
    out: dict[str, None] = {}
    for c in classes:
        for n in counts:
            for text, _lp in phrasings(RobotCommand(verb, c, n), lex):
                out[text] = None
    return list(out)
