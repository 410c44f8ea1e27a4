"""How object classes are named in speech: singular, plural, synonyms, mass nouns, categories.

The lexicon is the vocabulary side of the instruction likelihood: ``phrasing.py`` turns a robot
command into the sentences a person might say, and it needs to know that a ``wineglass`` is
said "wine glass" or "glass", that ``cereal`` takes no number ("the cereal"), and that
"cutlery" may stand for a fork, a knife or a spoon.

Class ids are lowercase with underscores (``tomato_sauce``); a class missing from the lexicon is
still speakable: its spoken form replaces ``_`` with a space and its plural adds "s".
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

from siftom.errors import ObservationError, unknown_name

_CLASS_RE = re.compile(r"^[a-z][a-z0-9_]*$")
_WORDS_RE = re.compile(r"^[a-z][a-z' ]*[a-z]$|^[a-z]$")
_IRREGULAR = {"knife": "knives", "loaf": "loaves", "leaf": "leaves", "potato": "potatoes",
              "tomato": "tomatoes", "man": "men", "mouse": "mice", "glass": "glasses"}


class LexiconError(ObservationError):
    """A lexicon file or entry is malformed."""


def pluralize(noun: str) -> str:
    """Return the English plural of a (possibly multi-word) noun; the last word is inflected."""
    head, _, last = noun.rpartition(" ")
    if last in _IRREGULAR:
        plural = _IRREGULAR[last]
    elif last.endswith(("s", "sh", "ch", "x", "z")):
        plural = last + "es"
    elif len(last) > 1 and last.endswith("y") and last[-2] not in "aeiou":
        plural = last[:-1] + "ies"
    else:
        plural = last + "s"
    return f"{head} {plural}" if head else plural


def spoken_form(obj_class: str) -> str:
    """Default spoken form of a class id: ``tomato_sauce`` -> ``tomato sauce``."""
    return obj_class.replace("_", " ").strip()


@dataclass(frozen=True)
class Name:
    """One way to name a class: singular and plural forms ("wine glass", "wine glasses")."""

    singular: str
    plural: str


@dataclass(frozen=True)
class LexEntry:
    """How one object class is spoken.

    Attributes:
        obj_class: the class id, e.g. ``wineglass``.
        names: the names, preferred first (the first is the canonical name).
        mass: a mass noun takes no number and no indefinite article ("the milk", "some milk").
    """

    obj_class: str
    names: tuple[Name, ...]
    mass: bool = False

    def __post_init__(self) -> None:
        if not _CLASS_RE.match(self.obj_class):
            raise LexiconError(
                f"class id {self.obj_class!r} must be lowercase letters, digits and underscores, "
                "e.g. 'tomato_sauce'"
            )
        if not self.names:
            raise LexiconError(f"class {self.obj_class!r} has no names; give at least 'singular'")
        for n in self.names:
            for form in (n.singular, n.plural):
                if not isinstance(form, str) or not _WORDS_RE.match(form):
                    raise LexiconError(
                        f"name {form!r} of class {self.obj_class!r} must be lowercase words "
                        "separated by single spaces, e.g. 'wine glass'"
                    )

    @property
    def singular(self) -> str:
        """Canonical singular name."""
        return self.names[0].singular

    @property
    def plural(self) -> str:
        """Canonical plural name."""
        return self.names[0].plural

    @property
    def synonyms(self) -> tuple[Name, ...]:
        """Names other than the canonical one."""
        return self.names[1:]

    @classmethod
    def default(cls, obj_class: str) -> LexEntry:
        """Entry for a class the lexicon does not list: spoken form of its id, regular plural."""
        word = spoken_form(obj_class.lower())
        return cls(obj_class.lower(), (Name(word, pluralize(word)),))


@dataclass(frozen=True)
class Category:
    """A word that covers several classes ("cutlery" -> fork, knife, spoon).

    ``countable`` categories are plural nouns that take a number ("three dishes"); the others
    are mass nouns ("the cutlery").
    """

    word: str
    classes: tuple[str, ...]
    countable: bool = False

    def __post_init__(self) -> None:
        if not _WORDS_RE.match(self.word):
            raise LexiconError(f"category word {self.word!r} must be lowercase words, e.g. 'cutlery'")
        if len(self.classes) < 1:
            raise LexiconError(f"category {self.word!r} covers no classes; list at least one")


@dataclass(frozen=True)
class Lexicon:
    """Names of object classes and category words. Immutable and hashable.

    Build with :func:`default_lexicon`, :meth:`from_dict` or directly from entries.
    """

    entries: tuple[LexEntry, ...]
    categories: tuple[Category, ...] = ()
    _index: dict[str, LexEntry] = field(init=False, repr=False, compare=False, hash=False)
    _classes: tuple[str, ...] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        index: dict[str, LexEntry] = {}
        for e in self.entries:
            if e.obj_class in index:
                raise LexiconError(f"class {e.obj_class!r} is listed twice in the lexicon; merge the entries")
            index[e.obj_class] = e
        object.__setattr__(self, "_index", index)
        object.__setattr__(self, "_classes", tuple(index))
        for c in self.categories:
            missing = [k for k in c.classes if k not in index]
            if missing:
                raise LexiconError(
                    f"category {c.word!r} covers classes not in the lexicon: {', '.join(missing)}; "
                    "add entries for them or remove them from the category"
                )

    def __hash__(self) -> int:  # the generated hash would walk every entry on each lookup
        return hash(self.fingerprint)

    @property
    def classes(self) -> tuple[str, ...]:
        """Class ids listed in the lexicon, in order."""
        return self._classes

    def __contains__(self, obj_class: object) -> bool:
        return obj_class in self._index

    def entry(self, obj_class: str) -> LexEntry:
        """The entry for a class; an unlisted class gets :meth:`LexEntry.default`."""
        e = self._index.get(obj_class)
        return e if e is not None else LexEntry.default(obj_class)

    def require(self, obj_class: str) -> LexEntry:
        """The entry for a listed class; raise UnknownNameError (with suggestions) otherwise."""
        if obj_class not in self._index:
            raise unknown_name("object class", obj_class, self._index)
        return self._index[obj_class]

    def categories_of(self, obj_class: str) -> tuple[Category, ...]:
        """Category words that cover a class."""
        return tuple(c for c in self.categories if obj_class in c.classes)

    def words(self) -> set[str]:
        """Every word used in a name or category (for phoneme pre-computation)."""
        out: set[str] = set()
        for e in self.entries:
            for n in e.names:
                out.update(n.singular.split())
                out.update(n.plural.split())
        for c in self.categories:
            out.update(c.word.split())
        return out

    @cached_property
    def fingerprint(self) -> str:
        """Stable hash of the content; used as a cache key."""
        blob = json.dumps(self.to_dict(), sort_keys=True).encode()
        return hashlib.sha1(blob).hexdigest()[:16]

    # -- serialisation -------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form, the inverse of :meth:`from_dict`."""
        classes: dict[str, Any] = {}
        for e in self.entries:
            d: dict[str, Any] = {"singular": e.singular, "plural": e.plural}
            if e.synonyms:
                d["synonyms"] = [[n.singular, n.plural] for n in e.synonyms]
            if e.mass:
                d["mass"] = True
            classes[e.obj_class] = d
        cats = {
            c.word: {"classes": list(c.classes), "countable": c.countable} for c in self.categories
        }
        return {"classes": classes, "categories": cats}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Lexicon:
        """Build from ``{"classes": {id: {...}}, "categories": {word: {...}}}``.

        A class entry has ``singular`` (default: spoken form of the id), ``plural`` (default: the
        regular plural), ``synonyms`` (a list of singular strings or ``[singular, plural]``
        pairs) and ``mass`` (bool). A category has ``classes`` (list of ids) and ``countable``.
        """
        if not isinstance(d, Mapping) or "classes" not in d:
            raise LexiconError(
                'a lexicon must be a mapping with a "classes" key, e.g. '
                '{"classes": {"fork": {"singular": "fork"}}}'
            )
        raw_classes = d["classes"]
        if not isinstance(raw_classes, Mapping):
            raise LexiconError('"classes" must map class ids to entries')
        entries = [_entry_from_dict(k, v) for k, v in raw_classes.items()]
        raw_cats = d.get("categories", {}) or {}
        if not isinstance(raw_cats, Mapping):
            raise LexiconError('"categories" must map a word to {"classes": [...]}')
        cats = []
        for word, v in raw_cats.items():
            if isinstance(v, list | tuple):
                v = {"classes": v}
            if not isinstance(v, Mapping) or not isinstance(v.get("classes"), list | tuple):
                raise LexiconError(f'category {word!r} needs "classes": a list of class ids')
            _check_keys(f"category {word!r}", v, {"classes", "countable"})
            cats.append(Category(str(word), tuple(str(c) for c in v["classes"]), bool(v.get("countable", False))))
        return cls(tuple(entries), tuple(cats))

    def with_names(self, names: Iterable[tuple[str, Iterable[str]]]) -> Lexicon:
        """This lexicon with more spoken names per class (a world's ``names``): a listed class
        keeps its canonical name and gains the others as synonyms; an unlisted class is named
        by them, the first preferred. Plurals are the regular ones (``pluralize``)."""
        return _with_names(self, tuple((c, tuple(n)) for c, n in names))

    def restrict(self, classes: Iterable[str]) -> Lexicon:
        """A lexicon with only the given classes (categories keep their members that remain)."""
        keep = [self.entry(c) for c in dict.fromkeys(classes)]
        ids = {e.obj_class for e in keep}
        cats = []
        for c in self.categories:
            members = tuple(k for k in c.classes if k in ids)
            if members:
                cats.append(Category(c.word, members, c.countable))
        return Lexicon(tuple(keep), tuple(cats))


@lru_cache(maxsize=64)
def _with_names(lex: Lexicon, names: tuple[tuple[str, tuple[str, ...]], ...]) -> Lexicon:
    if not names:
        return lex
    extra = dict(names)
    entries = []
    for e in lex.entries:
        said = extra.pop(e.obj_class, ())
        have = {n.singular for n in e.names}
        more = tuple(Name(w, w if e.mass else pluralize(w)) for w in said if w not in have)
        entries.append(LexEntry(e.obj_class, e.names + more, e.mass) if more else e)
    for cls, said in extra.items():
        entries.append(LexEntry(cls, tuple(Name(w, pluralize(w)) for w in said)))
    return Lexicon(tuple(entries), lex.categories)


def lexicon_for(world: Any) -> Lexicon:
    """The lexicon a world is spoken in: the built-in one with the world's own ``names``."""
    names = getattr(world, "names", ())
    return default_lexicon().with_names(names) if names else default_lexicon()


def _check_keys(what: str, d: Mapping[str, Any], allowed: set[str]) -> None:
    extra = set(d) - allowed
    if extra:
        raise LexiconError(f"{what} has unknown keys {sorted(extra)}; allowed: {sorted(allowed)}")


def _entry_from_dict(obj_class: str, v: Any) -> LexEntry:
    if v is None:
        v = {}
    if not isinstance(v, Mapping):
        raise LexiconError(f"entry for class {obj_class!r} must be a mapping, got {type(v).__name__}")
    _check_keys(f"class {obj_class!r}", v, {"singular", "plural", "synonyms", "mass"})
    singular = v.get("singular") or spoken_form(str(obj_class))
    if not isinstance(singular, str):
        raise LexiconError(f"'singular' of class {obj_class!r} must be a string")
    mass = bool(v.get("mass", False))
    plural = v.get("plural") or (singular if mass else pluralize(singular))
    names = [Name(singular, plural)]
    for s in v.get("synonyms", []) or []:
        if isinstance(s, str):
            names.append(Name(s, pluralize(s)))
        elif isinstance(s, list | tuple) and len(s) == 2 and all(isinstance(x, str) for x in s):
            names.append(Name(s[0], s[1]))
        else:
            raise LexiconError(
                f"synonym {s!r} of class {obj_class!r} must be a string or a [singular, plural] pair"
            )
    return LexEntry(str(obj_class), tuple(names), mass)


# -- the default vocabulary ------------------------------------------------------------------

_HOUSEHOLD: dict[str, dict[str, Any]] = {
    "plate": {},
    "fork": {},
    "knife": {},
    "spoon": {"synonyms": ["teaspoon"]},
    "wineglass": {"singular": "wine glass", "plural": "wine glasses", "synonyms": ["glass"]},
    "waterglass": {"singular": "water glass", "plural": "water glasses", "synonyms": ["glass"]},
    "mug": {"synonyms": ["cup", "coffee mug"]},
    "bowl": {},
}

_KITCHEN_MASS = ["cereal", "milk", "coffee", "sugar", "tea", "pasta", "tomato_sauce", "lettuce", "dressing", "flour", "bread", "bacon", "butter", "cheese", "ham", "jam", "honey", "peanut_butter", "oatmeal", "rice", "chicken", "salt", "pepper", "olive_oil", "garlic", "yogurt", "orange_juice", "chocolate", "syrup"]
_KITCHEN_COUNT = ["cucumber", "egg", "beans", "onion", "tomato", "potato", "carrot", "apple", "banana", "tortilla", "cup"]
_KITCHEN_EXTRA: dict[str, dict[str, Any]] = {
    "beans": {"singular": "beans", "plural": "beans", "synonyms": [["can of beans", "cans of beans"]]},
    "tomato_sauce": {"synonyms": ["pasta sauce"]},
    "olive_oil": {"synonyms": ["oil"]},
    "orange_juice": {"synonyms": ["juice", "o j"]},
    "peanut_butter": {},
    "syrup": {"synonyms": ["maple syrup"]},
    "yogurt": {"synonyms": ["yoghurt"]},
    "dressing": {"synonyms": ["salad dressing"]},
    "cup": {"synonyms": ["mug"]},
}

_CATEGORIES: dict[str, dict[str, Any]] = {
    "cutlery": {"classes": ["fork", "knife", "spoon"], "countable": False},
    "silverware": {"classes": ["fork", "knife", "spoon"], "countable": False},
    "utensils": {"classes": ["fork", "knife", "spoon"], "countable": True},
    "dishes": {"classes": ["plate", "bowl"], "countable": True},
    "glasses": {"classes": ["wineglass", "waterglass"], "countable": True},
    "drinks": {"classes": ["milk", "coffee", "tea", "orange_juice"], "countable": True},
    "spices": {"classes": ["salt", "pepper"], "countable": True},
    "vegetables": {"classes": ["lettuce", "cucumber", "onion", "tomato", "potato", "carrot"], "countable": True},
}


def default_lexicon() -> Lexicon:
    """Household table-setting classes plus kitchen ingredients, with synonyms and categories."""
    return _default()


_DEFAULT: Lexicon | None = None


def _default() -> Lexicon:
    global _DEFAULT
    if _DEFAULT is None:
        classes: dict[str, dict[str, Any]] = dict(_HOUSEHOLD)
        for c in _KITCHEN_MASS:
            classes.setdefault(c, {}).update({"mass": True, **_KITCHEN_EXTRA.get(c, {})})
        for c in _KITCHEN_COUNT:
            classes.setdefault(c, {}).update(_KITCHEN_EXTRA.get(c, {}))
        _DEFAULT = Lexicon.from_dict({"classes": classes, "categories": _CATEGORIES})
    return _DEFAULT


KITCHEN_ITEMS: tuple[str, ...] = tuple(
    c for c in [*_KITCHEN_MASS, *_KITCHEN_COUNT, "bowl", "plate"]
)
HOUSEHOLD_CLASSES: tuple[str, ...] = tuple(_HOUSEHOLD)
