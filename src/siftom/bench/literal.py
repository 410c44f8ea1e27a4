"""The literal-ASR baseline: read the 1-best transcript like a classic command parser.

The parser knows the names of the object classes in the scene (the lexicon's names, synonyms
and plurals) and counts (digits and number words), and nothing about the person's goal:

* the object is the first class name in the transcript (longest match first, so "wine glass"
  beats "glass"); a name shared by two classes ("glass") goes to the first in lexicon order;
  category words ("cutlery", "dishes") name no single class and are ignored;
* the count is a number said just before the name ("three forks", "3 more forks");
  otherwise 1 for a singular name, and for a bare plural ("the forks", "the rest of the
  forks") every such object not yet at the target, at most ``max_count`` (the largest count
  in the command space);
* ``fetch`` domains (kitchen) always bring one.

When no class name is heard the robot does nothing: :data:`NONE` (speedup 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phrasing import NUMBER_WORDS
from siftom.world.commands import MAX_COUNT, RobotCommand

NONE = "none"
NUMBERS: dict[str, int] = {w: i for i, w in enumerate(NUMBER_WORDS)}
NUMBERS.update({"couple": 2, "pair": 2, "both": 2, "dozen": 12})
_SKIP_BEFORE_NAME = frozenset({"more", "of", "the", "extra", "other", "clean"})


@dataclass(frozen=True)
class LiteralParse:
    """What the parser read: the class, the count and whether the count was said."""

    obj_class: str
    count: int
    count_said: bool
    plural: bool


@lru_cache(maxsize=64)
def _name_table(classes: tuple[str, ...], lexicon: Lexicon) -> tuple[tuple[tuple[str, ...], str, bool], ...]:
    """(words, class, plural) for every name of the classes, longest first, lexicon order."""
    order = {c: i for i, c in enumerate(lexicon.classes)}
    ranked = sorted(classes, key=lambda c: (order.get(c, len(order)), c))
    table: list[tuple[tuple[str, ...], str, bool]] = []
    seen: set[tuple[str, ...]] = set()
    for cls in ranked:
        for name in lexicon.entry(cls).names:
            for form, plural in ((name.singular, False), (name.plural, True)):
                words = tuple(form.split())
                if words not in seen:  # a shared name goes to the first class
                    seen.add(words)
                    table.append((words, cls, plural and name.plural != name.singular))
    table.sort(key=lambda t: -len(t[0]))  # stable: keeps lexicon order among equal lengths
    return tuple(table)


def _number(word: str) -> int | None:
    if word.isdigit():
        return int(word)
    return NUMBERS.get(word)


def parse_literal(text: str, classes: Sequence[str], lexicon: Lexicon | None = None) -> LiteralParse | None:
    """Find the first object name and its count in ``text``; None when no name is heard."""
    lex = lexicon or default_lexicon()
    words = "".join(c if c.isalnum() or c == "'" else " " for c in (text or "").lower()).split()
    table = _name_table(tuple(sorted(set(classes))), lex)
    for i in range(len(words)):
        for name, cls, plural in table:
            if tuple(words[i : i + len(name)]) == name:
                count = None
                j = i - 1
                while j >= 0 and words[j] in _SKIP_BEFORE_NAME and i - j <= 3:
                    j -= 1
                if j >= 0 and i - j <= 3:
                    count = _number(words[j])
                if count is not None and count >= 1:
                    return LiteralParse(cls, count, True, plural)
                return LiteralParse(cls, 1, False, plural)
    return None


def literal_command(
    text: str,
    scenario: object,
    lexicon: Lexicon | None = None,
    max_count: int = MAX_COUNT,
) -> RobotCommand | None:
    """The robot command a literal parser makes of ``text`` in ``scenario`` (None: do nothing).

    Args:
        text: the 1-best transcript.
        scenario: a Scenario (its world's classes, verb, start state and goal target are used).
        lexicon: class names (default :func:`default_lexicon`).
        max_count: the largest count the robot is ever asked for.
    """
    from siftom.world.model import HELD

    world = scenario.world  # type: ignore[attr-defined]
    verb = scenario.verb  # type: ignore[attr-defined]
    p = parse_literal(text, world.classes, lexicon)
    if p is None:
        return None
    if verb == "fetch":
        return RobotCommand(verb, p.obj_class, 1)
    now = scenario.states()[-1]  # type: ignore[attr-defined]
    target = scenario.goals[0].target  # type: ignore[attr-defined]
    avail = sum(1 for i, loc in enumerate(now.item_at)
                if loc not in (HELD, target) and world.items[i].cls == p.obj_class)
    if p.count_said:
        n = p.count
    elif p.plural:
        n = max_count
    else:
        n = 1
    n = max(1, min(n, avail, max_count if not p.count_said else n))
    return RobotCommand(verb, p.obj_class, n)
