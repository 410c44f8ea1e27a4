"""The English of what the robot says, in one place: number agreement, articles and counts.

The robot names objects by the world's own spoken names (the lexicon's singular and plural). The
helpers here turn a name into the words around it: "the scissors are", "the glue", "two plates",
"Which one: the glue or the tape?". A name that reads as plural ("scissors", "water glasses",
"jeans") takes "are"; a count of one is said only where counts matter (two commands of one class
that differ in count), otherwise the object is "the NAME".

``lemminflect`` is used for plurals when it is installed; without it a small set of English rules
and irregular forms gives the same answer for the names the built-in domains use.
"""

from __future__ import annotations

from collections.abc import Sequence

from siftom.likelihood.numbers import number_word

# nouns that are plural in form and take a plural verb, one object or many
PLURALIA_TANTUM = frozenset({
    "scissors", "glasses", "jeans", "trousers", "pants", "shorts", "tongs", "pliers", "tweezers", "binoculars",
    "headphones", "earphones", "goggles", "pyjamas", "pajamas", "clothes", "oats", "noodles", "sweets",
    "chopsticks", "leftovers", "groceries", "dishes", "cutlery sets", "spices",
})
# singular nouns that end in s and are not plural
SINGULAR_IN_S = frozenset({"glass", "bus", "gas", "lens", "dress", "mattress", "hummus", "couscous", "asparagus",
                           "molasses", "news", "swiss", "citrus", "cactus", "octopus", "mess", "class", "grass",
                           "floss", "moss", "harness", "iris", "chess", "lotus", "plus", "canvas", "christmas"})
_IRREGULAR = {"knife": "knives", "loaf": "loaves", "leaf": "leaves", "shelf": "shelves", "half": "halves",
              "potato": "potatoes", "tomato": "tomatoes", "mango": "mangoes", "child": "children", "mouse": "mice",
              "foot": "feet", "tooth": "teeth", "person": "people", "man": "men", "woman": "women", "fish": "fish",
              "sheep": "sheep", "cheese": "cheeses", "wife": "wives", "life": "lives", "cactus": "cacti"}


def plural(name: str) -> str:
    """The plural of a spoken name: its last word inflected ("water glass" -> "water glasses")."""
    words = name.split()
    if not words:
        return name
    last = words[-1]
    if is_plural(last):
        return name
    return " ".join([*words[:-1], _plural_word(last)])


def _plural_word(word: str) -> str:
    low = word.lower()
    if low in _IRREGULAR:
        return _IRREGULAR[low]
    try:  # optional: better coverage of English
        from lemminflect import getInflection  # type: ignore[import-not-found,unused-ignore]

        forms = getInflection(word, tag="NNS")
        if forms:
            return str(forms[0])
    except ImportError:
        pass
    if low.endswith(("s", "x", "z", "ch", "sh")):
        return word + "es"
    if low.endswith("y") and len(low) > 1 and low[-2] not in "aeiou":
        return word[:-1] + "ies"
    return word + "s"


def is_plural(name: str) -> bool:
    """Whether a spoken name takes a plural verb: "scissors", "water glasses", "forks" (not "glass",
    "hummus")."""
    words = name.lower().split()
    if not words:
        return False
    if name.lower() in PLURALIA_TANTUM or words[-1] in PLURALIA_TANTUM:
        return True
    last = words[-1]
    if last in SINGULAR_IN_S or last.endswith(("ss", "us", "is")):
        return False
    return last.endswith("s") and len(last) > 2


def be(name: str) -> str:
    """"is" or "are", agreeing with ``name``."""
    return "are" if is_plural(name) else "is"


def the(name: str) -> str:
    """"the NAME"."""
    return f"the {name}"


def counted(n: int, singular: str, plural_name: str | None = None) -> str:
    """"one plate", "three water glasses" (``plural_name``: the world's own plural, else inflected)."""
    return f"{number_word(n)} {singular if n == 1 else (plural_name or plural(singular))}"


def already_with_you(name: str) -> str:
    """"the honey is already with you", "the scissors are already with you"."""
    return f"the {name} {be(name)} already with you"


def none_here(name: str) -> str:
    """"there is no banana here", "there are no scissors here"."""
    return f"there {be(name)} no {name} here"


def sorry(text: str) -> str:
    """``text`` as a sentence the robot says: "Sorry, the honey is already with you."."""
    text = text.strip().rstrip(".")
    return f"Sorry, {text}." if text else "Sorry."


def either(options: Sequence[str]) -> str:
    """"the glue or the tape", "the cereal, the honey or the sugar"."""
    opts = list(options)
    if len(opts) <= 1:
        return "".join(opts)
    return ", ".join(opts[:-1]) + " or " + opts[-1]


def which_one(options: Sequence[str]) -> str:
    """"Which one: the glue or the tape?"."""
    return f"Which one: {either(options)}?"


def noun(singular: str, plural_name: str, count: int) -> str:
    """The name for ``count`` objects: the world's plural past one, unless the name is plural
    already ("scissors")."""
    if count == 1 or is_plural(singular):
        return singular
    return plural_name or plural(singular)


def object_phrase(singular: str, plural_name: str, count: int, *, counted: bool, mass: bool = False) -> str:
    """How the robot names ``count`` objects of a class: "the cereal", "the scissors", "one plate",
    "three water glasses". A count is said where it matters (``counted``: a command that brings a
    number of objects), never for one of a mass noun or of a plural-only name."""
    if count == 1 and (not counted or mass or is_plural(singular)):
        return f"the {singular}"
    return f"{number_word(count)} {noun(singular, plural_name, count)}"
