"""The understanding benchmark's items: generated from the templates over worlds of both domains,
each with what a listener should understand, and the scoring of an answer against one
(:mod:`siftom.bench.understanding` runs them).
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from siftom.bench.understanding_blind import (
    BLIND,
    BLIND_KINDS,
    EXTRA_KINDS,
    items_dir,
    load_items,
    scene_of,
    world_files,
)
from siftom.bench.understanding_records import Expect, Item
from siftom.bench.utterances import (
    CONFUSIONS,
    COUNTED,
    DEFAULT_WORLDS,
    DOMAINS,
    KINDS,
    MAX_COUNT,
    NUMBER_WORDS,
    PER_KIND,
    SETS,
    TEMPLATES,
    WORLD_SEEDS,
)
from siftom.errors import DatasetError

__all__ = [
    "BLIND", "BLIND_KINDS", "EXTRA_KINDS", "Expect", "Item", "carried_out", "generate_items", "items_dir", "load_items",
    "offered", "outcome", "said_why", "scene_of", "understood", "world_files",
]


@dataclass(frozen=True)
class _Said:
    """An object as said: its class, the count said and the words for it."""

    cls: str
    count: int | None
    singular: str
    plural: str


@dataclass(frozen=True)
class _World:
    """What the templates need of a world: its classes, names, counts and the person's goal."""

    domain: str
    classes: tuple[str, ...]
    available: dict[str, int]
    singular: dict[str, str]
    plural: dict[str, str]
    names: frozenset[str]
    unneeded: tuple[str, ...]
    absent: tuple[tuple[str, str], ...]  # (class, its name) of known objects not here

    @property
    def counted(self) -> bool:
        return self.domain in COUNTED


def _ngrams(phrase: str) -> set[str]:
    words = phrase.split()
    return {" ".join(words[i:j]) for i in range(len(words)) for j in range(i + 1, len(words) + 1)}


def _names_any(phrase: str, names: Iterable[str]) -> bool:
    """Whether some words of ``phrase`` are one of ``names``, or ``phrase`` is some words of one
    ("coffee" of "coffee mug")."""
    names = set(names)
    return bool(_ngrams(phrase) & names) or any(phrase in _ngrams(n) for n in names)


def _world_info(scenario: Any) -> _World:
    from siftom.likelihood.lexicon import default_lexicon, lexicon_for

    world = scenario.world
    lex = lexicon_for(world)
    classes = tuple(world.classes)
    available = dict(Counter(it.cls for it in world.items))
    names = frozenset(w for c in classes for n in lex.entry(c).names for w in (n.singular, n.plural))
    goal = set(dict(scenario.goal.counts))
    touched = {world.items[a.obj].cls for a in scenario.actions if 0 <= a.obj < len(world.items)}
    unneeded = tuple(c for c in classes if c not in goal and c not in touched) or tuple(
        c for c in classes if c not in goal)
    known = default_lexicon()
    absent = tuple((c, known.entry(c).singular) for c in known.classes if c not in classes
                   and not any(_names_any(w, names) for n in known.entry(c).names for w in (n.singular, n.plural)))
    return _World(scenario.domain, classes, available, {c: lex.entry(c).singular for c in classes},
                  {c: lex.entry(c).plural for c in classes}, names, unneeded, absent)


def _confusion(w: _World, cls: str, set_name: str) -> tuple[str, str] | None:
    """The misheard words for ``cls`` in this set, when they name no object of the world."""
    options = CONFUSIONS.get(cls, ())
    k = {"dev": 0, "heldout": 1}.get(set_name, min(1, len(options) - 1))
    if not 0 <= k < len(options):
        return None
    sing, plural = options[k]
    if _names_any(sing, w.names) or _names_any(plural, w.names):
        return None
    return sing, plural


def _np(s: _Said, counted: bool) -> str:
    """The noun phrase of an object said: "the cereal", "the forks", "three forks"."""
    if not counted:
        return f"the {s.singular}"
    if s.count is None:
        return f"the {s.plural}"
    return f"{NUMBER_WORDS[s.count]} {s.plural}"


def _be(s: _Said, counted: bool) -> str:
    """The verb "is" or "are" for the object said."""
    word = s.plural if counted else s.singular
    return "are" if counted or word.endswith("s") else "is"


def _count(w: _World, classes: Sequence[str], rng: np.random.Generator, always: bool = False) -> int | None:
    """A count to say for ``classes`` in a counted domain (None: none said)."""
    if not w.counted:
        return None
    if not always and rng.random() < 0.5:
        return None
    top = min(MAX_COUNT, *(w.available[c] for c in classes))
    return int(rng.integers(2, top + 1)) if top >= 2 else None


def _said(w: _World, cls: str, count: int | None) -> _Said:
    return _Said(cls, count, w.singular[cls], w.plural[cls])


def _pick(pool: Sequence[str], key: Sequence[int], j: int) -> str:
    """The j-th of a shuffle of ``pool`` seeded with ``key``: the items of one world and kind
    (one key) name different objects while the pool lasts."""
    order = np.random.default_rng([*key, len(pool)]).permutation(len(pool))
    return pool[int(order[j % len(pool)])]


def _other(pool: Sequence[str], not_this: str, rng: np.random.Generator) -> str:
    rest = [c for c in pool if c != not_this]
    return rest[int(rng.integers(len(rest)))]


def _fill(template: str, w: _World, x: _Said | None = None, y: _Said | None = None) -> str:
    """The template with {x}, {x_be}, {y} and {y_be} filled in."""
    values: dict[str, str] = {}
    if x is not None:
        values.update(x=_np(x, w.counted), x_be=_be(x, w.counted))
    if y is not None:
        values.update(y=_np(y, w.counted), y_be=_be(y, w.counted))
    return template.format(**values)


def _make(kind: str, template: str, w: _World, rng: np.random.Generator, key: Sequence[int], j: int,
          set_name: str) -> tuple[str, Expect] | None:
    """(text, expected) of the j-th item of ``kind`` in a world from ``template``; None when the
    world has no object the kind needs. ``key`` seeds the order the objects are taken in."""
    pool = list(w.classes)
    if kind in ("plain", "any_object"):
        cls = _pick(pool if kind == "plain" else list(w.unneeded), key, j)
        n = _count(w, [cls], rng)
        return _fill(template, w, _said(w, cls, n)), Expect(True, ((cls, n),))
    if kind == "misheard":
        heard = [c for c in pool if _confusion(w, c, set_name) is not None]
        if not heard:
            return None
        cls = _pick(heard, key, j)
        conf = _confusion(w, cls, set_name)
        assert conf is not None
        n = _count(w, [cls], rng)
        return _fill(template, w, _Said(cls, n, *conf)), Expect(True, ((cls, n),))
    if kind == "correction":
        y = _pick(pool, key, j)
        x = _other(pool, y, rng)
        n = _count(w, [x, y], rng)
        return _fill(template, w, _said(w, x, n), _said(w, y, n)), Expect(True, ((y, n),))
    if kind == "negation":
        cls = _pick(pool, key, j)
        return _fill(template, w, _said(w, cls, None)), Expect(False)
    if kind == "context":
        x = _pick(pool, key, j)
        y = _other(pool, x, rng)
        n = _count(w, [x], rng)
        return _fill(template, w, _said(w, x, n), _said(w, y, None)), Expect(True, ((x, n),))
    if kind == "compound":
        x = _pick(pool, key, j)
        y = _other(pool, x, rng)
        n = _count(w, [x, y], rng)
        return _fill(template, w, _said(w, x, n), _said(w, y, n)), Expect(True, ((x, n), (y, n)))
    if kind == "count":
        if not w.counted:
            return None
        cls = _pick([c for c in pool if w.available[c] >= 2], key, j)
        n = _count(w, [cls], rng, always=True)
        return _fill(template, w, _said(w, cls, n)), Expect(True, ((cls, n),))
    if kind == "absent":
        if not w.absent:
            return None
        cls = _pick([c for c, _ in w.absent], key, j)
        name = dict(w.absent)[cls]
        return _fill(template, w, _Said(cls, None, name, name)), Expect(True, (), absent=name)
    if kind == "nonrequest":
        cls = _pick(pool, key, j)
        return _fill(template, w, _said(w, cls, None)) if "{x}" in template else template, Expect(False)
    raise ValueError(f"unknown kind {kind!r}; kinds: {', '.join(KINDS)}")


def _check_set(set_name: str) -> None:
    if set_name not in SETS:
        raise DatasetError(f"unknown set {set_name!r}; choose one of {', '.join(SETS)}")


def generate_items(set_name: str = "dev", world_seed: int | None = None, worlds: int = DEFAULT_WORLDS,
                   seed: int = 0, per_kind: int = PER_KIND) -> list[Item]:
    """The items of a set: ``per_kind`` items of every kind in ``worlds`` worlds of each domain.

    Args:
        set_name: ``dev``, ``heldout`` or ``unseen`` (its own templates and, by default, its own
            worlds).
        world_seed: the worlds' seed (default: :data:`WORLD_SEEDS` of the set).
        worlds: worlds per domain.
        seed: seed of every choice (objects, counts, templates).
        per_kind: items per kind and world.

    Returns:
        The items, interleaved so that any prefix mixes kinds and domains (``--limit``).
    """
    from siftom.people.stimuli import check_seed, resolve_scenario, select_scenarios

    _check_set(set_name)
    check_seed(seed)
    if worlds < 1 or per_kind < 1:
        raise DatasetError(f"worlds and items per kind must be >= 1, got {worlds} and {per_kind}")
    ws = WORLD_SEEDS[set_name] if world_seed is None else world_seed
    s = SETS.index(set_name)
    keyed: list[tuple[tuple[int, int, int, int], Item]] = []
    for d, domain in enumerate(DOMAINS):
        for k, (sid, sseed) in enumerate(select_scenarios(domain, worlds, ws)):
            assert sseed is not None  # a world seed draws every scenario
            w = _world_info(resolve_scenario(sid, domain, sseed))
            for t, kind in enumerate(KINDS):
                templates = TEMPLATES[set_name][kind]
                order = np.random.default_rng([seed, s, d, 1000 + t]).permutation(len(templates))
                key = [seed, s, d, k, t]
                rng = np.random.default_rng(key)
                for j in range(per_kind):
                    template = templates[int(order[(k * per_kind + j) % len(templates)])]
                    made = _make(kind, template, w, rng, key, j, set_name)
                    if made is None:
                        continue
                    text, expect = made
                    item = Item(f"{set_name}/{sid}/{kind}/{j}", kind, domain, sseed, text, expect, sid, template)
                    keyed.append(((j, k, t, d), item))
    return [item for _, item in sorted(keyed, key=lambda p: p[0])]


# -- scoring -------------------------------------------------------------------------------------


def _squash(text: str) -> str:
    return re.sub(r"[\s_]+", "", text.lower())


def _cls(cmd: Any) -> str:
    return str(getattr(cmd, "obj_class", cmd))


def carried_out(answer: Any) -> tuple[Any, ...]:
    """The commands ``answer`` carries out (none when it asks or does nothing)."""
    if getattr(answer, "action", None) != "act":
        return ()
    got = tuple(getattr(answer, "carry_out", None) or ())
    if got:
        return got
    cmd = getattr(answer, "command", None)
    return (cmd,) if cmd is not None else ()


def offered(answer: Any) -> tuple[str, ...]:
    """The classes of the commands the robot's question offers (none when it does not ask)."""
    if getattr(answer, "action", None) != "ask":
        return ()
    out = []
    for c in tuple(getattr(getattr(answer, "decision", None), "options", None) or ()):
        m = re.fullmatch(r"\w+\((\w+)(?:,\d+)?\)", str(c))
        out.append(m.group(1) if m else str(c))
    return tuple(out)


def said_why(answer: Any) -> str:
    """What the robot says when it declines: the decline of the answer and of each of its parts
    (its explanation, ``reason``, is for whoever reads the record, not said to the person)."""
    decisions = (getattr(answer, "decision", None), *tuple(getattr(answer, "part_decisions", None) or ()))
    return " ".join(str(getattr(d, "declined", "") or "") for d in decisions).strip()


def understood(item: Item, answer: Any) -> bool:
    """Whether ``answer`` (an :class:`~siftom.answer.Answer`) understood ``item``.

    * a refused object (``refused``): never carried out, never offered in a question; with no
      target, that is all;
    * an absent object: the robot does nothing and says why, naming the object ("Sorry, there is
      no banana here."); staying silent ignores the person;
    * no request: the robot does nothing (``action`` none, no command carried out);
    * a request: the utterance model heard a request (a reply: the robot's parts or what it
      carries out name the objects), the classes of ``answer.parts`` (one command per
      understood target) are the expected ones (as a multiset; each ``optional`` class may come
      once more), and every count said is the count of a part of its class; with
      ``over_supply``, parts of the target's classes only, none above the count said.
    """
    e = item.expect
    action = getattr(answer, "action", None)
    if ({_cls(c) for c in carried_out(answer)} | set(offered(answer))) & set(e.refused):
        return False
    if e.absent:
        return action == "none" and _squash(e.absent) in _squash(said_why(answer))
    if not e.request:
        return action == "none" and getattr(answer, "command", None) is None
    if not e.targets:
        return True
    parts = tuple(getattr(answer, "parts", None) or ())
    if item.pending:
        parts = parts or carried_out(answer)
    else:
        u = getattr(answer, "understanding", None)
        if u is None or not bool(getattr(u, "request", False)):
            return False
    got: dict[str, list[int]] = {}
    for p in parts:
        got.setdefault(_cls(p), []).append(int(getattr(p, "count", 1)))
    want: dict[str, list[int | None]] = {}
    for cls, n in e.targets:
        want.setdefault(cls, []).append(n)
    if e.over_supply:
        return bool(got) and set(got) <= set(want) and all(
            n is None or c <= n for cls, counts in got.items() for c in counts for n in want[cls])
    for cls in e.optional:
        if len(got.get(cls, [])) > len(want.get(cls, [])):
            got[cls].pop()
            if not got[cls]:
                del got[cls]
    if {c: len(v) for c, v in got.items()} != {c: len(v) for c, v in want.items()}:
        return False
    for cls, counts in want.items():
        left = list(got[cls])
        for n in counts:
            if n is None:
                continue
            if n not in left:
                return False
            left.remove(n)
    return True


def outcome(item: Item, answer: Any) -> dict[str, bool | None]:
    """What went wrong, beside :func:`understood` (None where it cannot happen to the item):

    * ``nothing``: a request got no action, no question and, for an object that is not here, no
      decline said;
    * ``other_object``: a request was carried out on an object not asked for (an absent one's
      stand-in, a refused one, or any class outside the targets and their ``optional``);
    * ``acted_unasked`` / ``asked_unasked``: nobody asked, and the robot acted / asked back.
    """
    e = item.expect
    action = getattr(answer, "action", None)
    done = {_cls(c) for c in carried_out(answer)}
    if e.request:
        if e.targets:
            other = bool(done - {c for c, _ in e.targets} - set(e.optional))
        elif e.absent:
            other = bool(done)
        else:
            other = bool(done & set(e.refused))
        silent = action == "none" and not (e.absent and said_why(answer))
        return {"nothing": silent if e.wants_object or e.absent else None, "other_object": other,
                "acted_unasked": None, "asked_unasked": None}
    return {"nothing": None, "other_object": None, "acted_unasked": action == "act", "asked_unasked": action == "ask"}
