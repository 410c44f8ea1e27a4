"""The understanding benchmark: does the robot get what people say to it right?

Items are short utterances to the robot, generated from templates over worlds of both domains
(``kitchen-v0``, ``household-table-v0``) drawn with ``--world-seed`` (``select_scenarios``), each
with what a listener should understand (:class:`Expect`): whether anybody asked the robot for
something, the objects asked for with the count said, or the object named that is not here.

Kinds (:data:`KINDS`): ``plain`` requests, ``misheard`` (a word that sounds like an object of the
world but is not its name: "the serial"), ``correction`` ("not the X, the Y": Y), ``negation``
("don't bring the X": no request), ``context`` ("the X for the Y": X), ``compound`` ("the X and
the Y": both), ``count`` ("four bowls", household), ``any_object`` (an object the person's goal
does not need), ``absent`` (a known object that is not in the world: nothing done, the reason
names it) and ``nonrequest`` (thanks, room talk, questions to nobody).

Three sets of wordings, written apart: ``dev``, ``heldout`` and ``unseen`` share no template, so
a model built on the dev wordings can be checked on wordings it never saw (and on other worlds:
world seed 201 for dev, 202 for held-out, 203 for unseen). Conditions: ``text`` (the words
themselves), ``clean`` (spoken by a TTS voice) and ``10dB`` (the same clip in recorded household
noise at 10 dB SNR).

Everything random is drawn from generators seeded with ``[seed, set, domain, world, kind]``, so
the same arguments give the same items. The templates are benchmark data only: nothing in the
product reads them.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import DatasetError

KINDS = ("plain", "misheard", "correction", "negation", "context", "compound", "count", "any_object",
         "absent", "nonrequest")
SETS = ("dev", "heldout", "unseen")
KITCHEN = "kitchen-v0"
HOUSEHOLD = "household-table-v0"
DOMAINS = (KITCHEN, HOUSEHOLD)
# domains whose objects are asked for in numbers ("three forks"); a kitchen object is one item
COUNTED = (HOUSEHOLD,)
CONDITIONS = ("text", "clean", "10dB")
WORLD_SEEDS = {"dev": 201, "heldout": 202, "unseen": 203}
DEFAULT_WORLDS = 6  # per domain
PER_KIND = 2  # items per kind and world
VOICES = ("flite-slt", "flite-awb", "espeak-en-us+klatt", "hibari-heart")
NOISE = "recorded"
SNR_DB = 10.0
NUMBER_WORDS = {2: "two", 3: "three", 4: "four"}
MAX_COUNT = 4

# -- templates -----------------------------------------------------------------------------------
# {x}, {y}: a noun phrase with its determiner ("the cereal", "the forks", "three forks");
# {x_be}, {y_be}: "is" or "are" for them. Kinds ``negation`` and ``nonrequest`` take {x} or nothing.

TEMPLATES: dict[str, dict[str, tuple[str, ...]]] = {
    "dev": {
        "plain": (
            "could you pass me {x}",
            "{x} please",
            "can you bring me {x}",
            "I need {x}",
            "please get {x}",
            "hey robot, grab {x} for me",
        ),
        "misheard": (
            "can you hand me {x}",
            "pass {x}, please",
            "I'd like {x}",
            "would you fetch {x}",
        ),
        "correction": (
            "no, not {x}, {y}",
            "can you hand me {x}, um, I mean {y}",
            "not {x}, {y} please",
            "bring me {x}, sorry, {y}",
            "get me {x}, no wait, I meant {y}",
        ),
        "negation": (
            "don't bring {x}",
            "I don't need {x}",
            "please don't get {x}",
            "we don't need {x} anymore",
            "you don't have to fetch {x}",
        ),
        "context": (
            "pass me {x} for {y}",
            "can you get me {x}, {y} {y_be} already here",
            "grab {x} from next to {y}",
            "I need {x} to go with {y}",
            "{x} please, I already have {y}",
        ),
        "compound": (
            "could you get me {x} and {y}",
            "bring me {x} and {y}",
            "{x} and {y}, please",
            "I need {x} and {y}",
        ),
        "count": (
            "bring me {x}",
            "could you get {x}",
            "I need {x} on the table",
            "{x}, please",
        ),
        "any_object": (
            "could you grab me {x}",
            "can I have {x}",
            "please bring {x} over here",
            "get me {x}, would you",
        ),
        "absent": (
            "bring me {x}",
            "could you pass me {x}",
            "I need {x} now",
            "can you fetch {x}",
        ),
        "nonrequest": (
            "thank you",
            "thanks, that's all",
            "the weather is nice today",
            "my phone battery is dead",
            "where did I leave my keys",
            "what time is it",
            "I saw {x} on sale at the store yesterday",
            "did you hear what happened at work today",
        ),
    },
    "heldout": {
        "plain": (
            "would you mind handing me {x}",
            "I could use {x} over here",
            "{x}, when you get a chance",
            "fetch {x} for me, would you",
            "go and get {x}",
            "robot, I want {x}",
        ),
        "misheard": (
            "could I get {x} please",
            "bring {x} here",
            "I'm looking for {x}",
            "any chance you could grab {x}",
        ),
        "correction": (
            "fetch {x}, actually, make that {y}",
            "{x}, no sorry, {y}",
            "bring me {y} instead of {x}",
            "I meant {y}, not {x}",
            "hand me {x}, scratch that, {y}",
        ),
        "negation": (
            "just leave {x} alone",
            "there's no need to bring {x}",
            "please don't touch {x}",
            "forget about {x}",
            "skip {x} for now",
        ),
        "context": (
            "I've got {y} already, just get me {x}",
            "to go with {y}, could you fetch {x}",
            "{y} {y_be} ready, now I need {x}",
            "fetch {x} from beside {y}",
            "for {y}, I'll need {x}",
        ),
        "compound": (
            "I'll need {x} as well as {y}",
            "grab {x}, and also {y}",
            "{x} plus {y}, please",
            "I want {x} and {y} over here",
        ),
        "count": (
            "could I have {x}",
            "{x} on the table, please",
            "set out {x}",
            "go get {x}",
        ),
        "any_object": (
            "would you bring {x} over",
            "I'd love {x} right now",
            "fetch me {x} please",
            "{x}, if you don't mind",
        ),
        "absent": (
            "would you hand me {x}",
            "go fetch {x}",
            "I'm after {x}",
            "could I get {x} from you",
        ),
        "nonrequest": (
            "cheers, that's everything",
            "I think it might rain later",
            "did anyone feed the cat",
            "that was a great movie last night",
            "hmm, who called me earlier",
            "I really should water the plants",
            "{x} {x_be} so expensive these days",
            "my sister is visiting next week",
        ),
    },
    # Written fresh, apart from both sets above, as people talk to a home robot: contractions,
    # fillers, politeness, indirect requests and clauses in either order.
    "unseen": {
        "plain": (
            "Be a dear and grab {x} for me.",
            "Um, can I get {x} when you're free?",
            "Hey, would you mind bringing over {x}?",
            "I could really use {x} right now.",
            "When you get a sec, pass me {x}, would you?",
            "Uh, {x} over here, if you could.",
            "Do you think you could fetch {x}?",
            "I'm gonna need {x} over here.",
        ),
        "misheard": (
            "Mind handing me {x} real quick?",
            "Um, I'd like {x}, if that's okay.",
            "Would you mind bringing {x} my way?",
            "Go ahead and grab {x}, thanks.",
            "Uh, could I trouble you for {x}?",
            "Think you could rustle up {x} for me?",
        ),
        "correction": (
            "I'm after {x}, oh, hang on, I mean {y}.",
            "Go grab {x}... hmm, on second thought, make it {y}.",
            "I need {x}, um, no, I meant {y}.",
            "Can you pass {x}? Scratch that, {y} instead.",
            "Uh, {x}, no wait, {y}, please.",
            "Hand me {x}. Hmm, actually, I'd rather have {y}.",
            "Would you get {x}, er, I mean {y}?",
        ),
        "negation": (
            "Don't worry about {x}, we're fine.",
            "Nah, forget about {x}, I changed my mind.",
            "Please don't grab {x}, I'm all set.",
            "We won't be needing {x} tonight.",
            "You can leave {x} alone, thanks.",
            "Um, skip {x}, I don't want any.",
            "Turns out I won't need {x} after all.",
        ),
        "context": (
            "Okay, {y} {y_be} out already, so I just need {x}.",
            "I've already got {y}, I just need {x} now.",
            "Right, I've sorted out {y}; what I still need is {x}.",
            "Seeing as {y} {y_be} here already, could you just round up {x}?",
            "Don't bother with {y}, I've got that covered. Just {x}, please.",
            "Could you bring {x} over by {y}?",
            "Now that I've got {y}, can you find me {x}?",
        ),
        "compound": (
            "Could you round up {x} and {y} for me, please?",
            "Um, I'll need {x}, and also {y}.",
            "Grab {x} for me, oh, and {y} as well.",
            "Can I get {x} plus {y}?",
            "I need {x} and, uh, {y} too, if you don't mind.",
            "Would you pass {x}? And {y} while you're at it.",
            "When you've got a second, I'm gonna need {x} and {y} over here.",
        ),
        "count": (
            "We've got guests, so um, could you set out {x}?",
            "I'll need {x} for everyone.",
            "Can you grab {x} from over there?",
            "Um, can we get {x} set out at our places?",
            "Mind grabbing {x}? We've got company.",
            "Bring over {x} when you can.",
            "It's not just me tonight, so {x}, please.",
        ),
        "any_object": (
            "Oh, while you're up, could you get me {x}?",
            "I know it's random, but can you bring {x}?",
            "Oh, before I forget, I'd like you to bring {x}.",
            "Okay, this is gonna sound odd, but I'd like {x}, please.",
            "Could you run and get {x}? Thanks a bunch.",
            "Pop over and get {x} for me, would you?",
        ),
        "absent": (
            "Do me a favor and dig out {x}, would you?",
            "Um, is there any way you could pass me {x}?",
            "Hey there, would you track down {x} for me?",
            "Would you get {x} for me?",
            "I'd love {x}, if it's not too much trouble.",
            "Go grab {x}, would you?",
        ),
        "nonrequest": (
            "Thanks, that's everything for now.",
            "Wow, it smells amazing in here.",
            "Hey Sam, did you remember to call your mom back?",
            "I already put {x} away, don't worry.",
            "Oh, I love how this room looks with the lights down.",
            "Jamie, are you done with {x}?",
            "Great job, that's exactly what I wanted.",
            "Huh, I didn't know we still had {x}.",
        ),
    },
}

# Words that sound like an object's name but are not a name of it: class -> ((singular, plural),
# ...). The dev set uses the first, the held-out set the second (a class with one is dev only),
# the unseen set the second or, for a class with one, the first.
# A confusion is used only where it names no object of the world (tomato -> potato only where
# there is no potato).
CONFUSIONS: dict[str, tuple[tuple[str, str], ...]] = {
    # kitchen
    "cereal": (("serial", "serials"), ("surreal", "surreals")),
    "flour": (("flower", "flowers"), ("floor", "floors")),
    "milk": (("silk", "silks"), ("mill", "mills")),
    "tea": (("tee", "tees"), ("key", "keys")),
    "coffee": (("toffee", "toffees"),),
    "honey": (("money", "money"), ("funny", "funny")),
    "butter": (("batter", "batters"), ("gutter", "gutters")),
    "pepper": (("paper", "papers"),),
    "salt": (("malt", "malts"), ("fault", "faults")),
    "rice": (("price", "prices"), ("dice", "dice")),
    "bread": (("bred", "bred"), ("thread", "threads")),
    "bacon": (("baking", "baking"), ("beacon", "beacons")),
    "cheese": (("cheeks", "cheeks"), ("chess", "chess")),
    "pasta": (("pastor", "pastors"), ("pastel", "pastels")),
    "egg": (("leg", "legs"), ("peg", "pegs")),
    "onion": (("union", "unions"), ("bunion", "bunions")),
    "carrot": (("parrot", "parrots"), ("carat", "carats")),
    "banana": (("bandana", "bandanas"), ("bonanza", "bonanzas")),
    "lettuce": (("let us", "let us"), ("lattice", "lattices")),
    "yogurt": (("yoga", "yoga"),),
    "chicken": (("thicken", "thicken"), ("checking", "checking")),
    "garlic": (("gaelic", "gaelic"),),
    "apple": (("ample", "ample"), ("chapel", "chapels")),
    "dressing": (("pressing", "pressings"),),
    "ham": (("hem", "hems"), ("hum", "hums")),
    "beans": (("beads", "beads"), ("jeans", "jeans")),
    "tomato": (("potato", "potatoes"),),
    # both
    "cup": (("cap", "caps"), ("pup", "pups")),
    "bowl": (("ball", "balls"), ("goal", "goals")),
    "plate": (("plane", "planes"), ("slate", "slates")),
    # household
    "fork": (("fort", "forts"), ("folk", "folks")),
    "knife": (("life", "lives"), ("knight", "knights")),
    "spoon": (("moon", "moons"), ("spool", "spools")),
    "mug": (("bug", "bugs"), ("hug", "hugs")),
    "wineglass": (("wine grass", "wine grasses"), ("wine class", "wine classes")),
    "waterglass": (("water grass", "water grasses"), ("water class", "water classes")),
}


# -- items ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Expect:
    """What a listener should understand from an item.

    Attributes:
        request: whether somebody asked the robot for something.
        targets: (object class, count said or None) for each object asked for.
        absent: the name of the object asked for that is not in the world ('' for none).
    """

    request: bool
    targets: tuple[tuple[str, int | None], ...] = ()
    absent: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"request": self.request, "targets": [[c, n] for c, n in self.targets],
                "absent": self.absent or None}


@dataclass(frozen=True)
class Item:
    """One utterance of the benchmark in one world.

    Attributes:
        id: ``SET/DOMAIN/wW-K/KIND/J``.
        kind: one of :data:`KINDS`.
        domain: the domain id.
        scenario_seed: the generator seed of the world (``world_scenario_seed``).
        text: what the person says.
        expect: what should be understood.
        scenario: the scenario id (``kitchen-v0/w201-0``).
        template: the template the text was made from.
    """

    id: str
    kind: str
    domain: str
    scenario_seed: int
    text: str
    expect: Expect
    scenario: str = ""
    template: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "domain": self.domain, "scenario": self.scenario,
                "scenario_seed": self.scenario_seed, "text": self.text, "template": self.template,
                "expected": self.expect.to_json()}


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


def understood(item: Item, answer: Any) -> bool:
    """Whether ``answer`` (an :class:`~siftom.answer.Answer`) understood ``item``.

    * an absent object: the robot does nothing and the reason names the object;
    * no request: the robot does nothing (``action`` none, no command carried out);
    * a request: the utterance model heard a request, the classes of ``answer.parts`` (one
      command per understood target) are the expected ones (as a multiset), and every count
      said is the count of a part of its class.
    """
    e = item.expect
    action = getattr(answer, "action", None)
    if e.absent:
        reason = str(getattr(getattr(answer, "decision", None), "reason", "") or "")
        return action == "none" and _squash(e.absent) in _squash(reason)
    if not e.request:
        return action == "none" and getattr(answer, "command", None) is None
    u = getattr(answer, "understanding", None)
    if u is None or not bool(getattr(u, "request", False)):
        return False
    got: dict[str, list[int]] = {}
    for p in tuple(getattr(answer, "parts", None) or ()):
        got.setdefault(str(p.obj_class), []).append(int(p.count))
    want: dict[str, list[int | None]] = {}
    for cls, n in e.targets:
        want.setdefault(cls, []).append(n)
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


# -- running -------------------------------------------------------------------------------------


def _plain(v: Any) -> Any:
    """``v`` with numpy scalars as Python ones (for JSON)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def scene_for(item: Item) -> Any:
    """The :class:`~siftom.inputs.SceneInput` of an item's world, with the scenario's own actions."""
    from siftom.inputs import resolve_scene
    from siftom.people.stimuli import resolve_scenario

    return resolve_scene(resolve_scenario(item.scenario, item.domain, item.scenario_seed))


def run_item(observer: Any, item: Item, scene: Any, heard: str | np.ndarray, *,
             condition: str = "text", voice: str | None = None) -> dict[str, Any]:
    """Ask ``observer`` about what was ``heard`` (a transcript or 16 kHz samples) of ``item`` in
    ``scene``; the result row (``understood`` by :func:`understood`)."""
    from siftom.errors import SiftomError

    t0 = time.perf_counter()
    row: dict[str, Any] = {"id": item.id, "kind": item.kind, "domain": item.domain, "scenario": item.scenario,
                           "condition": condition, "voice": voice, "text": item.text,
                           "expected": item.expect.to_json()}
    try:
        answer = observer.infer(scene, None, heard)
    except SiftomError as exc:
        return {**row, "heard": None, "understanding": None, "parts": [], "action": None, "command": None,
                "reason": None, "error": str(exc), "seconds": round(time.perf_counter() - t0, 4),
                "understood": False}
    u = getattr(answer, "understanding", None)
    cmd = answer.command
    row.update({
        "heard": answer.transcript,
        "understanding": _plain(u.to_json()) if u is not None else None,
        "parts": [str(p) for p in tuple(getattr(answer, "parts", None) or ())],
        "action": answer.action,
        "command": str(cmd) if cmd is not None else None,
        "reason": answer.decision.reason,
        "seconds": round(time.perf_counter() - t0, 4),
        "understood": understood(item, answer),
    })
    return row


def voices_available() -> tuple[str, ...]:
    """The benchmark's voices (:data:`VOICES`) whose TTS engine is installed here."""
    from siftom.speech.tts import VOICES as REGISTRY

    return tuple(v for v in VOICES if REGISTRY.spec(v).missing() is None)


def _stable(text: str) -> int:
    return int(hashlib.sha1(text.encode()).hexdigest()[:8], 16)


def speak(item: Item, voice: str) -> np.ndarray:
    """The item said by ``voice`` (16 kHz samples)."""
    from siftom.speech.tts import synthesize

    return synthesize(item.text, voice)


def add_noise(clean: np.ndarray, item: Item, seed: int = 0) -> np.ndarray:
    """``clean`` in the recorded household noise at 10 dB SNR, an excerpt seeded per item."""
    from siftom.speech.noise import get_noise, mix_at_snr

    return mix_at_snr(clean, get_noise(NOISE), SNR_DB, np.random.default_rng([seed, _stable(item.id)]))


def record(item: Item, condition: str, voice: str, seed: int = 0) -> np.ndarray:
    """The item spoken by ``voice`` in a recorded condition: ``clean`` or ``10dB``."""
    if condition not in CONDITIONS[1:]:
        raise DatasetError(f"no recording for condition {condition!r}; recorded conditions: clean, 10dB")
    clean = speak(item, voice)
    return clean if condition == "clean" else add_noise(clean, item, seed)


def as_recorded(x: np.ndarray) -> np.ndarray:
    """``x`` as a 16-bit PCM recording holds it: the same samples whether a clip was just made or
    read back from ``FILE.audio/``."""
    import io

    import soundfile as sf

    from siftom.speech.audio import wav_bytes

    got: np.ndarray = sf.read(io.BytesIO(wav_bytes(x)), dtype="float32")[0]
    return got


class _Recorder:
    """Recordings of the items, said once per item and voice; on disk only under ``folder``."""

    def __init__(self, seed: int, folder: Path | None) -> None:
        self.seed = seed
        self.folder = folder
        self._clean: tuple[str, np.ndarray] | None = None

    def __call__(self, item: Item, condition: str, voice: str) -> np.ndarray:
        from siftom.speech.audio import load_audio, write_wav

        path = None
        if self.folder is not None:
            key = hashlib.sha1(json.dumps([item.text, voice, condition, self.seed]).encode()).hexdigest()[:10]
            path = self.folder / f"{re.sub(r'[^A-Za-z0-9-]+', '_', item.id)}-{condition}-{key}.wav"
            if path.is_file():
                return load_audio(path)
        if condition not in CONDITIONS[1:]:
            raise DatasetError(f"no recording for condition {condition!r}; recorded conditions: clean, 10dB")
        tag = f"{item.id}|{voice}|{item.text}"
        if self._clean is None or self._clean[0] != tag:
            self._clean = (tag, speak(item, voice))
        x = as_recorded(self._clean[1] if condition == "clean" else add_noise(self._clean[1], item, self.seed))
        if path is not None:
            write_wav(path, x)
        return x


def _stem(out: Path) -> str:
    return out.name[: -len(".jsonl")] if out.name.endswith(".jsonl") else out.name


def summary_path(out: str | Path) -> Path:
    """``FILE.summary.json`` beside ``FILE.jsonl``."""
    p = Path(out)
    return p.with_name(_stem(p) + ".summary.json")


def _share(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    n = len(rows)
    ok = sum(1 for r in rows if r["understood"])
    return {"n": n, "understood": ok, "share": round(ok / n, 4) if n else None}


def summarize(rows: Sequence[dict[str, Any]], meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """Share understood per condition: overall, per kind, per domain and per kind and domain."""
    conds = [c for c in CONDITIONS if any(r["condition"] == c for r in rows)]
    out: dict[str, Any] = {**(meta or {}), "rows": len(rows), "overall": {}, "by_kind": {}, "by_domain": {},
                           "by_kind_domain": {}, "seconds_per_item": {}}
    for c in conds:
        rc = [r for r in rows if r["condition"] == c]
        out["overall"][c] = _share(rc)
        out["by_kind"][c] = {k: _share([r for r in rc if r["kind"] == k]) for k in KINDS
                             if any(r["kind"] == k for r in rc)}
        out["by_domain"][c] = {d: _share([r for r in rc if r["domain"] == d]) for d in DOMAINS
                               if any(r["domain"] == d for r in rc)}
        out["by_kind_domain"][c] = {f"{k}/{d}": _share([r for r in rc if r["kind"] == k and r["domain"] == d])
                                    for k in KINDS for d in DOMAINS
                                    if any(r["kind"] == k and r["domain"] == d for r in rc)}
        out["seconds_per_item"][c] = round(float(np.mean([r["seconds"] for r in rc])), 4) if rc else None
    return out


@dataclass
class Run:
    """A benchmark run: the rows (one per item and condition) and their summary."""

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    seconds: float = 0.0
    files: list[str] = field(default_factory=list)


def run_benchmark(items: Sequence[Item], conditions: Sequence[str] = ("text",), *, observer: Any = None,
                  seed: int = 0, out: str | Path | None = None, meta: dict[str, Any] | None = None,
                  progress: Callable[[int, int], None] | None = None) -> Run:
    """Run every item in every condition; write ``out`` (JSON lines) and its summary when given.

    Args:
        items: the items (:func:`generate_items`).
        conditions: of :data:`CONDITIONS`; ``clean`` and ``10dB`` speak each item with a voice of
            :func:`voices_available` (rotating).
        observer: the observer to ask (default: one from the settings).
        seed: seed of the noise excerpts.
        out: a ``.jsonl`` file for the rows; ``FILE.summary.json`` beside it, and the recordings
            under ``FILE.audio/`` (reused when the same run is repeated).
        meta: what the run was (set, seeds), copied into the summary.
        progress: called with (done, total) after each row.
    """
    from siftom.observer import Observer

    bad = [c for c in conditions if c not in CONDITIONS]
    if bad:
        raise DatasetError(f"unknown condition {bad[0]!r}; choose from {', '.join(CONDITIONS)}")
    voices: tuple[str, ...] = ()
    if any(c != "text" for c in conditions):
        voices = voices_available()
        if not voices:
            raise DatasetError(f"no voice of {', '.join(VOICES)} is installed for the recorded conditions; "
                               "install flite or espeak-ng (make sysdeps), or run --conditions text")
    ob = observer if observer is not None else Observer()
    out_path = Path(out) if out is not None else None
    rec = _Recorder(seed, out_path.with_name(_stem(out_path) + ".audio") if out_path is not None else None)
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    total = len(items) * len(conditions)
    sink = None
    if out_path is not None:
        out_path.parent.mkdir(parents=True, exist_ok=True)
        sink = out_path.open("w", encoding="utf-8")
    try:
        for i, item in enumerate(items):
            scene = scene_for(item)
            for c in conditions:
                voice = voices[i % len(voices)] if c != "text" else None
                heard: str | np.ndarray = item.text if voice is None else rec(item, c, voice)
                row = run_item(ob, item, scene, heard, condition=c, voice=voice)
                rows.append(row)
                if sink is not None:
                    sink.write(json.dumps(row) + "\n")
                    sink.flush()
                if progress is not None:
                    progress(len(rows), total)
    finally:
        if sink is not None:
            sink.close()
    secs = time.perf_counter() - t0
    info = {**(meta or {}), "items": len(items), "conditions": list(conditions), "voices": list(voices),
            "noise": NOISE if "10dB" in conditions else None, "seconds": round(secs, 1)}
    summary = summarize(rows, info)
    files: list[str] = []
    if out_path is not None:
        sp = summary_path(out_path)
        sp.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        files = [str(out_path), str(sp)]
    return Run(rows, summary, secs, files)


def table(summary: dict[str, Any]) -> Any:
    """A rich table of the share understood per kind (rows) and condition (columns)."""
    from rich.table import Table

    conds = list(summary["overall"])
    t = Table(title=f"understood, {summary.get('set', '?')} set",
              caption=f"world seed {summary.get('world_seed', '?')}, {summary.get('items', '?')} items")
    t.add_column("kind")
    for c in conds:
        t.add_column(c, justify="right")

    def cell(s: dict[str, Any] | None) -> str:
        if not s or not s["n"]:
            return "-"
        return f"{s['understood']}/{s['n']} {100 * s['share']:.0f} %"

    for k in KINDS:
        if any(k in summary["by_kind"][c] for c in conds):
            t.add_row(k, *(cell(summary["by_kind"][c].get(k)) for c in conds))
    t.add_section()
    for d in DOMAINS:
        if any(d in summary["by_domain"][c] for c in conds):
            t.add_row(d, *(cell(summary["by_domain"][c].get(d)) for c in conds))
    t.add_row("all", *(cell(summary["overall"][c]) for c in conds), style="bold")
    return t
