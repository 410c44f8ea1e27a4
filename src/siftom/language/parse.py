"""Read an utterance into object slots with roles: the syntax of the utterance model.

``grammar.lark`` chunks the words into noun phrases (the object slots) and marker words; this
module gives each slot its role from the markers around it, left to right:

* after a negation ("not the sugar", "don't bring the sugar", "instead of the sugar"): ``negated``;
* after a correction ("the jam, um, I mean the honey"): the slot before is ``retracted`` and
  the next one is a ``target``;
* after a relation word ("for the cereal", "from next to the oatmeal", "with the milk"), as the
  subject of a copula ("the sugar is already here", "my phone battery is dead") or after a
  possession ("I already have the sugar"): ``context``;
* after a question word with no request frame between ("where did I leave my keys"): ``context``
  (asked about, not asked for);
* any other slot: ``target``; a slot joined to the one before by "and" takes its role ("not the
  sugar and the honey" negates both, "the cereal and the sugar" asks for both).

A request frame (a request verb, "could you", "I need", "please") is recorded beside the slots:
the utterance model weighs it when deciding whether anybody asked (``understand.py``). The
grammar is read with lark's LALR parser: linear in the number of words.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from siftom.language.edits import (
    HESITATIONS,
    POSSESSIVE,
    VERB_NEG,
    rejects,
    repairs,
    uncontract,
)
from siftom.likelihood.numbers import NUMBER_WORDS
from siftom.likelihood.phonemes import normalize_text

# the longest utterance read (words); the rest is background (a request is said in far fewer)
MAX_WORDS = 64
GRAMMAR = Path(__file__).with_name("grammar.lark")
# markers that open a request frame (see _has_frame)
_FRAME = frozenset({"VERB", "MODAL", "WANT", "PLEASE"})
# the word classes a focused request keeps around its targets ("could you pass me ... please")
FRAME_WORDS = frozenset({"VERB", "ME", "MODAL", "YOU", "SELF", "WANT", "PLEASE"})
_COUNTS = {"both": 2, "pair": 2, "single": 1, "couple": 2}
# relation words a recogniser writes for a count ("bring me to plates" for "two plates")
_COUNT_LIKE = {"to": 2, "for": 4}
_ASKS_BEFORE = frozenset({"VERB", "ME", "WANT", "MEAN", "PLEASE"})  # where a count, not a relation, comes next
# negated auxiliaries: a bare word after one, before a noun phrase, is the verb they negate
_AUX_NEG = frozenset({"don't", "dont", "won't", "wont", "doesn't", "shouldn't", "needn't", "never"})
_AUXILIARIES = frozenset({"do", "does", "did", "will", "would", "should", "could", "can", "must"})


def _aux_neg(words: tuple[str, ...], at: int) -> bool:
    """Whether the negation at ``at`` negates a verb ("don't", "won't", "do not", "please never")."""
    return words[at] in _AUX_NEG or (words[at] == "not" and at > 0 and words[at - 1] in _AUXILIARIES)


# "I'd", "we'd": a wish ("I'd love the tea"), not a statement, whatever verb follows
_WISHING = frozenset({"i'd", "we'd"})


@dataclass(frozen=True)
class Slot:
    """One noun phrase of an utterance.

    Attributes:
        role: ``target``, ``context``, ``negated`` or ``retracted``.
        start, end: word positions of the whole phrase (determiners and count included).
        nouns: word positions of the words that name the object (may be empty: "could you get me the").
        count: the count said, None when none was.
    """

    role: str
    start: int
    end: int
    nouns: tuple[int, ...]
    count: int | None


@dataclass(frozen=True)
class Reading:
    """The words of an utterance, its slots and whether it holds a request frame."""

    words: tuple[str, ...]
    slots: tuple[Slot, ...]
    frame: bool
    question: bool
    truncated: bool = False
    kinds: tuple[str, ...] = ()  # the grammar's word class per word (WORD, DET, NEG, VERB, ...)

    def slot_words(self, slot: Slot) -> str:
        """The words naming the object of ``slot`` ("olive oil"), '' for none."""
        return " ".join(self.words[i] for i in slot.nouns)

    @property
    def targets(self) -> tuple[Slot, ...]:
        return tuple(s for s in self.slots if s.role == "target")

    def bare(self, slot: Slot) -> bool:
        """Whether ``slot`` is words alone, with no determiner or count ("skip", "chance")."""
        return slot.end - slot.start == len(slot.nouns)

    def focus(self, k: int | None = None, targets: tuple[Slot, ...] | None = None) -> str:
        """The words that ask for target ``k`` (None: every target) of ``targets`` (default: the
        target slots): the request frame and those slots, without negated, retracted or context
        slots and their markers. The text itself when there is no target."""
        targets = self.targets if targets is None else targets
        if not targets:
            return " ".join(self.words)
        keep = targets if k is None else (targets[min(k, len(targets) - 1)],)
        inside = {i for s in keep for i in range(s.start, s.end)}
        slotted = {i for s in self.slots for i in range(s.start, s.end)}
        return " ".join(w for i, (w, kind) in enumerate(zip(self.words, self.kinds, strict=True))
                        if i in inside or (i not in slotted and kind in FRAME_WORDS))


@lru_cache(maxsize=1)
def _parser() -> object:
    from lark import Lark

    return Lark(GRAMMAR.read_text(encoding="utf-8"), parser="lalr", lexer="basic")


def _count(word: str) -> int | None:
    if word in _COUNTS:
        return _COUNTS[word]
    return NUMBER_WORDS.index(word) if word in NUMBER_WORDS else None


@lru_cache(maxsize=16384)
def read(text: str) -> Reading:
    """The slots and roles of ``text`` (module doc); at most :data:`MAX_WORDS` words are read."""
    from lark import Token, Tree

    words = uncontract(tuple(normalize_text(text)))
    truncated = len(words) > MAX_WORDS
    words = words[:MAX_WORDS]
    if not words:
        return Reading((), (), False, False)
    tree = _parser().parse(" ".join(words))  # type: ignore[attr-defined]
    # pieces: ("np", [(kind, position)]) or (marker kind, position)
    pieces: list[tuple[str, list[tuple[str, int]]]] = []
    pos = 0
    for child in tree.children:
        if not isinstance(child, Tree):  # the grammar makes every piece a rule: np or marker
            continue
        toks = [t for t in child.scan_values(lambda v: isinstance(v, Token))]
        items = []
        for t in toks:
            items.append((str(t.type), pos))
            pos += 1
        pieces.append(("np" if child.data == "np" else items[0][0], items))
    kinds = tuple(k for _, items in pieces for k, _ in items)
    return _roles(words, pieces, truncated, kinds)


_Pieces = list[tuple[str, list[tuple[str, int]]]]


def _roles(words: tuple[str, ...], pieces: _Pieces, truncated: bool, kinds_of_words: tuple[str, ...]) -> Reading:
    r = _RoleReader(words, pieces, [k for k, _ in pieces], kinds_of_words)
    for j, (kind, items) in enumerate(pieces):
        if kind != "np":
            r.marker(j, kind, items)
        else:
            r.slot(j, items)
    return r.reading(truncated)


@dataclass
class _RoleReader:
    """The left-to-right reading of :func:`_roles`: what a marker leaves for the slots after it."""

    words: tuple[str, ...]
    pieces: _Pieces
    kinds: list[str]  # the kind of each piece ("np" or a marker)
    kinds_of_words: tuple[str, ...]
    slots: list[Slot] = field(default_factory=list)
    pending: str = ""  # the role the next slot takes from a marker before it
    asking: bool = False  # a question word with no request frame since
    frame: bool = False
    question: bool = False
    joined: bool = False  # "and" since the last slot
    told: set[int] = field(default_factory=set)  # slots of a statement the speaker made ("I saw the egg ...")
    own: bool = False  # the speaker's own doing since the last request frame ("I'll put the ham in it")
    related: set[int] = field(default_factory=set)  # slots made context by a relation word or a copula
    retract: int | None = None  # the target a correction takes back once another follows
    said_count: int | None = None  # a count heard as its homophone ("to", "for")
    asyndetic: list[int] = field(default_factory=list)  # targets followed by another with nothing between
    listed: bool = False  # a slot joined by "and": the targets are a list ("the oil, the coffee and the tea")
    in_list: set[int] = field(default_factory=set)  # slots joined to the one before by "and"
    _slot_piece: int = -1  # the piece of the last slot

    def _last_target(self) -> int | None:
        return next((k for k in range(len(self.slots) - 1, -1, -1) if self.slots[k].role == "target"), None)

    def _taken_back(self) -> int | None:
        """The target a correction takes back: the last one said as a noun phrase, past bare words
        between ("the syrup, oh, hang on, I mean the bread"); else the last target ("pasta, I
        mean rice")."""
        phrase = next((k for k in range(len(self.slots) - 1, -1, -1) if self.slots[k].role == "target"
                       and (k in self.in_list or self.slots[k].end - self.slots[k].start > len(self.slots[k].nouns))),
                      None)
        return phrase if phrase is not None else self._last_target()

    def marker(self, j: int, kind: str, items: list[tuple[str, int]]) -> None:
        words, kinds, pieces = self.words, self.kinds, self.pieces
        at = items[0][1]
        if kind in ("COP", "HAVE", "VERB", "MODAL", "WANT") and at > 0 and words[at - 1] == "to" \
                and self.pending == "context":
            self.pending = ""  # "to" before a verb is its infinitive ("has to be", "to get"): it relates nothing
        if repairs(words, self.kinds_of_words, at, kind) and self._last_target() is not None:
            kind = "MEAN"  # "the jam, never mind, the honey", "make that the honey", "three mugs, no, three cups"
        elif kind == "FILLER" and words[at] == "but" and at > 0 and words[at - 1] in ("anything", "everything"):
            kind = "NEG"  # "anything but the sugar": the sugar is refused
        elif kind == "NEG" and words[at] in VERB_NEG and (at + 1 >= len(words)
                                                           or self.kinds_of_words[at + 1] not in ("DET", "WORD", "NUM")):
            return  # "before I forget, ...", "leave it": no object follows to refuse
        if kind == "NEG" and rejects(words, self.kinds_of_words, at):
            # a discourse "no" ("no, the flour", "the jam, no, the honey", "no I need the
            # oats"): what came before is taken back, the next slot is asked for
            self.retract = self._taken_back()
            self.pending = "target"
        elif kind == "NEG":
            self.pending = "negated"
        elif kind == "MEAN":
            # "the jam, I mean the honey": the target before is taken back when another follows
            self.retract = self._taken_back()
            self.pending = "target"
        elif kind == "CTX" and words[at] in _COUNT_LIKE and j > 0 and kinds[j - 1] in _ASKS_BEFORE \
                and (self.frame or self.pending == "target") and words_of(pieces, j + 1)[:1] == ("WORD",):
            # "bring me to water glasses", "for bowls": with nothing asked for yet, a relation
            # word before a bare noun is a count the recogniser wrote as its homophone
            self.said_count = _COUNT_LIKE[words[at]]
            self.pending = self.pending if self.pending == "negated" else ""
        elif kind == "CTX" and self.pending != "negated" and _seeks(words, kinds, pieces, j):
            # "I'm looking for the jeans", "we're after the cereal": the relation word is the
            # speaker's verb's own ("look for", "ask for", "be after"), its object what they want
            self.pending, self.frame = "target", True
        elif kind == "CTX" and self.pending != "negated":
            self.pending = "context"
        elif kind == "HAVE" and _verb_before_me(kinds, j):
            self.frame = True  # "has me the beans" as heard for "pass me the beans": no possession
        elif kind == "HAVE" and self.pending != "negated" and not _asks_to_have(kinds, j) \
                and not (at + 1 < len(words) and words[at + 1] == "to"):
            self.pending = "context"  # "I already have the sugar"
        elif kind == "COP" and self.slots and j > 0 and kinds[j - 1] == "np" and self.pending != "negated" \
                and words[at - 1] != "to":
            self.pending = "context"  # the predicate of a statement about a slot ("the weather is nice")
        elif kind == "WH":
            self.asking, self.question = True, True
        elif kind == "SELF" and words[items[0][1]] not in _WISHING and _tells(words_of(pieces, j + 1)):
            self.asking = True  # "I saw ...", "we bought ...": the speaker tells, nobody is asked
        elif kind == "VERB" and _speaker_does(words, kinds, pieces, j):
            # "where did I put that", "I'll put the ham in it": the speaker is the verb's subject, so
            # it tells what they do (or ask about their own doing); nobody is asked for the object
            self.asking, self.own = True, True
        elif kind == "AND":
            self.joined = True
            return
        elif kind in _FRAME or kind == "ME":
            self.frame = self.frame or _has_frame(kinds, j)
            if kind in ("VERB", "MODAL") and self.pending == "context":
                self.pending = ""  # "I need to get the X": "to" before a verb relates nothing
            if kind in ("VERB", "MODAL"):
                self.asking, self.own = False, False
        self.joined = False if kind not in ("FILLER",) else self.joined

    def slot(self, j: int, items: list[tuple[str, int]]) -> None:
        words, kinds, slots = self.words, self.kinds, self.slots
        before = next((k for k in reversed(kinds[:j]) if k != "FILLER"), "")
        if items[0][0] == "WORD" and (before in ("SELF", "YOU", "MODAL") or (
                before == "NEG" and _aux_neg(words, _last(self.pieces, j, "NEG")) and len(items) == 1
                and words_of(self.pieces, j + 1)[:1] in (("DET",), ("NUM",)))):
            # a bare word after a subject, a modal or a negated auxiliary is a verb, not an object
            # ("I'd love the tea", "I saw eggs", "you know", "I should water the plants", "don't
            # drag the pasta" as a recogniser wrote "don't grab"); the words after it, if any, are
            # the slot
            if before == "SELF" and words[_last(self.pieces, j, "SELF")] in _WISHING:
                self.frame = True
            items = items[1:]
            if not items:
                return
        if len(items) == 1 and items[0][0] == "WORD" and _verb_before_me(kinds, j):
            # "drink me the napkins", "fix me a sandwich": a word opening a clause before "me" and an
            # object is the verb of a request (a request verb the recogniser misheard, or one the
            # grammar does not list), not an object
            self.frame = True
            return
        nouns = tuple(p for k, p in items if k == "WORD")
        counts = [c for k, p in items if k in ("NUM", "DET") for c in [_count(words[p])] if c is not None]
        if self.retract is not None:
            s = slots[self.retract]
            slots[self.retract] = Slot("retracted", s.start, s.end, s.nouns, s.count)
            self.retract = None
        if self.said_count is not None and not counts:
            counts, self.said_count = [self.said_count], None
        if self.joined and slots:
            role = slots[-1].role
        elif self.pending:
            role = self.pending
            if self.pending == "context":
                self.related.add(len(slots))
        elif self.asking:
            role = "context"
            if not self.question and not self.own:
                self.told.add(len(slots))
        else:
            role = "target"
        # "the sugar is already here": the subject of a copula is context
        if role == "target" and _is_here(kinds, j):
            role = "context"
            self.related.add(len(slots))
        elif role == "target" and _before_negated_verb(words, self.pieces, j) \
                and not repairs(words, self.kinds_of_words, self.pieces[j + 1][1][0][1], "NEG"):
            # "stop, don't grab the pasta", "the kids don't want the milk": a slot before a negated
            # verb that takes an object of its own is that verb's subject, or a clause of its own
            # ("the jam, never mind, the honey" is a repair)
            role = "context"
        continued = items[0][0] == "DET" and words[items[0][1]] == "of" and bool(slots) and self._slot_piece == j - 1
        if continued:
            role = slots[-1].role  # "a bit of brown sugar", "a can of beans": one phrase
        if role == "target" and slots and slots[-1].role == "target" and not self.joined and not continued and nouns \
                and all(k == "FILLER" and words[self.pieces[i][1][0][1]] in HESITATIONS
                        for i, k in enumerate(kinds[self._slot_piece + 1:j], self._slot_piece + 1)) \
                and self._slot_piece >= 0 and _parallel(words, self.kinds_of_words, slots[-1].start, items[0][1]) \
                and not _is_here(kinds, j):
            self.asyndetic.append(len(slots) - 1)  # "the jam the honey": a repair, unless a list follows
        if self.joined:
            self.listed = True
            self.in_list.add(len(slots))
        slots.append(Slot(role, items[0][1], items[-1][1] + 1, nouns, counts[0] if counts else None))
        self._slot_piece = j
        self.pending, self.joined = "", False

    def reading(self, truncated: bool) -> Reading:
        if not self.listed:
            # two objects asked for with nothing between them: the second repairs the first (a
            # list of two says "and"; in spoken repairs of commands many have no edit term)
            for k in self.asyndetic:
                s = self.slots[k]
                self.slots[k] = Slot("retracted", s.start, s.end, s.nouns, s.count)
        slots, frame = self.slots, self.frame
        if frame and self.told:
            # a statement before a request ("I think we're out of milk, could you bring some"): what
            # it mentions is what the request is about
            slots = [Slot("target", s.start, s.end, s.nouns, s.count) if k in self.told else s
                     for k, s in enumerate(slots)]
        if frame and self.related and not any(x.role == "target" for x in slots):
            # a request asks for something: when every slot read as context, the first one related
            # is the object ("can you get me peanut butter chicken it's already here" as heard)
            k = min(self.related)
            slots[k] = Slot("target", slots[k].start, slots[k].end, slots[k].nouns, slots[k].count)
        slots = _anaphora(slots)
        return Reading(self.words, tuple(slots), frame, self.question, truncated, self.kinds_of_words)


def _parallel(words: tuple[str, ...], kinds: tuple[str, ...], a: int, b: int) -> bool:
    """Whether the phrases starting at ``a`` and ``b`` start alike, as a repair restates ("the jam
    the honey", "three mugs three cups"); "the cereal some honey" (a recogniser's words run on)
    and "the plate my way" (whose or where) are no repair."""
    if kinds[a] != kinds[b] or words[b] in POSSESSIVE:
        return False
    return words[a] == words[b] if kinds[a] == "DET" else kinds[a] in ("NUM", "WORD")


def _anaphora(slots: list[Slot]) -> list[Slot]:
    """A target with no words ("bring some", "pass me that") refers to the last object mentioned
    before it that was not negated: that slot is the target and the empty one goes."""
    out = list(slots)
    for k, s in enumerate(slots):
        if s.role != "target" or s.nouns or any(x.role == "target" and x.nouns for x in slots):
            continue
        before = [i for i in range(k) if slots[i].role == "context" and slots[i].nouns]
        if before:
            b = slots[before[-1]]
            out[before[-1]] = Slot("target", b.start, b.end, b.nouns, b.count)
            out[k] = Slot("context", s.start, s.end, s.nouns, s.count)
    return out


def _last(pieces: list[tuple[str, list[tuple[str, int]]]], j: int, kind: str) -> int:
    """The word position of the last piece of ``kind`` before ``j``."""
    for k in range(j - 1, -1, -1):
        if pieces[k][0] == kind:
            return pieces[k][1][0][1]
    return 0


def words_of(pieces: list[tuple[str, list[tuple[str, int]]]], j: int) -> tuple[str, ...]:
    """The word classes of the piece at ``j`` (empty past the end)."""
    return tuple(k for k, _ in pieces[j][1]) if j < len(pieces) else ()


def _tells(nxt: tuple[str, ...]) -> bool:
    """"I" or "we" followed by a verb the grammar does not know as a request ("I saw", "we
    bought"): a statement. The verb is read as the first word of a bare noun phrase."""
    return bool(nxt) and nxt[0] == "WORD"


# modals that make "I <modal> <verb>" the speaker's own plan ("I'll put", "we will take")
_PLANS = frozenset({"will", "shall", "'ll"})
# subjects before which a request verb is no statement: "let's" invites the robot in; "I'm" and
# "we're" take no bare verb ("I'm hand the tortilla" is a recogniser's run-on, not English)
_NOT_PLANS = frozenset({"let's", "i'm", "we're"})


def _speaker_does(words: tuple[str, ...], kinds: list[str], pieces: _Pieces, j: int) -> bool:
    """Whether the request verb at piece ``j`` has the speaker as its subject: "I" or "we" right
    before it, or before "will"/"shall" before it ("I'll put", "where did I put", "we will get"),
    and not after a modal that asks ("can I get", "could we have" ask the robot) or a wish ("I'd
    get"); "let's", "I'm" and "we're" are no such subject (:data:`_NOT_PLANS`)."""
    k = j - 1
    while k >= 0 and kinds[k] == "FILLER":
        k -= 1
    if k >= 1 and kinds[k] == "MODAL" and words[pieces[k][1][0][1]] in _PLANS:
        k -= 1
    if k < 0 or kinds[k] != "SELF":
        return False
    subject = words[pieces[k][1][0][1]]
    if subject in _WISHING or subject in _NOT_PLANS or (j + 1 < len(kinds) and kinds[j + 1] == "ME"):
        return False  # nobody brings themselves something: "we bring me the beans" misheard "could you"
    return not (k >= 1 and kinds[k - 1] == "MODAL")


# relation words that take the object a subject is after ("I'm looking for the X", "I'm after the X")
_SEEKING = frozenset({"for", "after"})


def _seeks(words: tuple[str, ...], kinds: list[str], pieces: _Pieces, j: int) -> bool:
    """Whether the relation word at piece ``j`` ("for", "after") follows the speaker as subject
    with at most a bare verb between ("I'm looking for", "we are after", "I'm asking for"): a
    prepositional verb whose object is what the speaker seeks, not a relation to another object
    ("the bowl for the cereal")."""
    if words[pieces[j][1][0][1]] not in _SEEKING:
        return False
    k = j - 1
    while k >= 0 and kinds[k] == "FILLER":
        k -= 1
    if k >= 0 and kinds[k] == "np" and len(pieces[k][1]) == 1 and pieces[k][1][0][0] == "WORD":
        k -= 1  # the bare verb ("looking"), read by the grammar as a one-word phrase
    if k >= 0 and kinds[k] == "COP":
        k -= 1  # "I am looking for"
    return k >= 0 and kinds[k] == "SELF" and words[pieces[k][1][0][1]] not in ("let's",)


def _has_frame(kinds: list[str], j: int) -> bool:
    """Whether the marker at ``j`` opens a request frame: a request verb, a modal ("could you",
    "can I have"), a want ("I need", "we still need"), "please"."""
    k = kinds[j]
    if k in ("VERB", "PLEASE"):
        return True
    if k == "MODAL":
        return any(x in ("YOU", "SELF") for x in kinds[j + 1:j + 3])
    if k == "WANT":  # with its subject: "I need", "we still need" (a bare "need an" is no frame)
        return any(x == "SELF" for x in kinds[max(0, j - 3):j])
    return False


def _before_negated_verb(words: tuple[str, ...], pieces: list[tuple[str, list[tuple[str, int]]]], j: int) -> bool:
    """Whether the slot at ``j`` is followed by a negated verb ("don't", "won't") with an object
    after it."""
    if j + 1 >= len(pieces) or pieces[j + 1][0] != "NEG" or not _aux_neg(words, pieces[j + 1][1][0][1]):
        return False
    return any(kind == "np" for kind, _ in pieces[j + 2:])


def _verb_before_me(kinds: list[str], j: int) -> bool:
    """Whether the piece at ``j`` opens a clause and is followed by "me" (or "us") and an object:
    the imperative "<verb> me <object>" of a request, whatever the verb was heard as."""
    before = next((k for k in reversed(kinds[:j]) if k != "FILLER"), "")
    return before in ("", "AND", "PLEASE") and kinds[j + 1:j + 2] == ["ME"] and kinds[j + 2:j + 3] == ["np"]


def _asks_to_have(kinds: list[str], j: int) -> bool:
    """"can I have", "could we have", "I'd like to have": a request, not a possession."""
    before = kinds[max(0, j - 3):j]
    return "MODAL" in before or "WANT" in before or "CTX" in before


def _is_here(kinds: list[str], j: int) -> bool:
    """A slot at ``j`` that is the subject of a copula: a statement about the object ("the sugar
    is already here", "my phone battery is dead"), not a request for it."""
    return j + 2 < len(kinds) and kinds[j + 1] == "COP" and kinds[j + 2] not in ("PLEASE", "FILLER")
