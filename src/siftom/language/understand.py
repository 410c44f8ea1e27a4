"""The utterance model: did anybody ask the robot for something, and for what (docs/understanding.md).

A reading of the words (``parse.read``) gives object slots with roles. Each slot is named by the
class of the world whose words it sounds most like (exactly, or as a recogniser misheard it:
the relative phoneme cost of ``background.MeaningVocabulary`` against the chance level random
words reach, ``nearness.CHANCE_R``), or by a name the lexicon knows for an object that is not in
the world ("banana" where there is none).

**Nobody asked is a hypothesis.** Two generative stories compete for the words:

* *a request*: a person asks the robot for an object, usually with a request frame ("could you",
  "pass me", "I need", "please") and a target slot that names it -- possibly misheard, or lost
  in noise ("we still need the ...");
* *no request*: the words are about something else (thanks, room talk, a question to nobody, a
  recogniser's words for noise); they rarely hold a frame, and a slot names an object only by
  chance.

A reading falls in one cell (a request frame or none, crossed with what its target slots do),
and each kind of recogniser is a :class:`Channel`: the two distributions over the cells, under a
request and under nobody asked (``OPEN_CELLS``, ``SCENE_CELLS``). Every recogniser that heard the
utterance is a :class:`Hearing` with its reliability; :func:`understand_heard` weighs them all
(with even prior odds, log-odds(request) is the sum over hearings of the log ratio of each one's
cell probabilities under the two hypotheses), so no one transcript decides. A transcript read
through a channel stated for the words as said (``open``) is those words with probability its
reliability, and else a mishearing whose cell is drawn as any utterance's is, which says nothing
about either hypothesis; a channel counted on a recogniser's own outputs (``scene``) holds its
errors already, and its reliability tempers it.
docs/understanding.md ("Channels") gives the reasoning, the data each table was counted or stated
on, and what ``siftom bench understanding`` measured with them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from siftom.language.parse import Reading, Slot, read
from siftom.language.record import Mention, Understanding
from siftom.likelihood.lexicon import Lexicon, default_lexicon, pluralize
from siftom.likelihood.phonemes import word_phonemes

PRIOR_REQUEST = 0.5  # an utterance the robot heard is as likely a request as not


@dataclass(frozen=True)
class Naming:
    """What a slot's words name: a class of the world (``obj_class``), how near (relative cost
    ``r`` and the chance level ``threshold``), or a known object absent from the world (``named``)."""

    obj_class: str | None
    r: float
    threshold: float
    exact: bool = False
    named: str = ""

    @property
    def near(self) -> bool:
        return self.obj_class is not None and (self.exact or self.r <= self.threshold)


class Namer:
    """Names slots by the classes of one world (built once per classes and lexicon)."""

    def __init__(self, classes: Sequence[str], lexicon: Lexicon | None = None) -> None:
        from siftom.likelihood.background import MeaningVocabulary

        self.lexicon = lexicon or default_lexicon()
        self.classes = tuple(classes)
        own: dict[str, set[str]] = {}  # meaning word -> classes it names
        self.exact: dict[str, str] = {}  # a whole name (singular or plural) -> class
        for c in self.classes:
            entry = self.lexicon.entry(c)
            for n in entry.names:
                for form in (n.singular, n.plural, pluralize(n.singular)):
                    self.exact.setdefault(form, c)
                    self.exact.setdefault(form.replace(" ", ""), c)  # "wineglass" as a recogniser writes it
                    for w in form.split():
                        own.setdefault(w, set()).add(c)
        self.vocab = MeaningVocabulary(own)
        # the spoken forms of each class a slot is compared with (its names, words run together)
        self.forms: dict[str, tuple[str, ...]] = {}
        for c in self.classes:
            forms = {f.replace(" ", "") for n in self.lexicon.entry(c).names
                     for f in (n.singular, n.plural, pluralize(n.singular))}
            for cat in self.lexicon.categories_of(c):  # "the cutlery" names a fork, a knife, a spoon
                forms |= {cat.word.replace(" ", ""), pluralize(cat.word).replace(" ", "")}
                for form in (cat.word, pluralize(cat.word)):
                    self.exact.setdefault(form, c)
            self.forms[c] = tuple(sorted(forms))
        self.row_classes = [sorted(own[w]) for w in self.vocab.order]
        present = set(self.classes)
        self.absent: dict[str, str] = {}  # a name of a class the lexicon knows but the world lacks
        for c in self.lexicon.classes:
            if c in present:
                continue
            for n in self.lexicon.entry(c).names:
                for form in (n.singular, n.plural, pluralize(n.singular)):
                    if form not in self.exact:
                        self.absent.setdefault(form, n.singular)

    def costs(self, words: Sequence[str]) -> list[float]:
        """How unlike each class (in :attr:`classes`) the slot's words sound, in [0, 1]: the least
        :func:`phone_distance` of a word, or two adjacent words run together, to a name of the
        class (its whole name or one of its words, singular or plural); 0 when the slot says it."""
        said = self._said_name(words)
        if said is not None:  # a name was said: it is what the slot says ("wine glasses", not "glasses")
            spans = ["".join(words[said[0]:said[1]])]
        else:
            spans = [w for w in words] + [words[i] + words[i + 1] for i in range(len(words) - 1)]
        return [min((phone_distance(sp, form) for sp in spans for form in self.forms[c]), default=1.0)
                for c in self.classes]

    def _said_name(self, words: Sequence[str]) -> tuple[int, int] | None:
        """The span of the last, longest name (of the world or the lexicon) the words say."""
        for end in range(len(words), 0, -1):
            for start in range(end):
                said = " ".join(words[start:end])
                if said in self.exact or said in self.absent:
                    return start, end
        return None

    def name(self, words: Sequence[str]) -> Naming:
        """The class the words name best (module doc)."""

        if not words:
            return Naming(None, math.inf, 0.0)
        # a name said in the slot: the last one (the head of an English noun phrase comes last:
        # "the sugar cereal"), the longest there ("olive oil" before "oil")
        at = self._said_name(words)
        if at is not None:
            said = " ".join(words[at[0]:at[1]])
            if said in self.exact:
                return Naming(self.exact[said], 0.0, 0.0, exact=True)
            if at[1] < len(words):
                # the name of an absent object modifies a head that follows ("the coffee marks" for
                # "the coffee mugs"): the head names the object when it sounds like one of the world
                head = self._nearest(words[at[1]:])
                if head.near:
                    return head
            return Naming(None, math.inf, 0.0, named=self.absent[said])
        return self._nearest(words)

    def _nearest(self, words: Sequence[str]) -> Naming:
        """The class whose names the words (one or two adjacent) sound most like."""
        from siftom.likelihood.nearness import chance_threshold

        best_r, best_c, best_n = math.inf, None, 0
        spans = [(w,) for w in words] + [tuple(words[i:i + 2]) for i in range(len(words) - 1)]
        for span in spans:
            phones = tuple(p for w in span for p in word_phonemes(w))
            if not phones or not len(self.vocab.order):
                continue
            costs = self.vocab.relative_costs_phones(phones, 1.0 if len(span) > 1 else None)
            k = int(costs.argmin())
            if costs[k] < best_r:
                best_r, best_c, best_n = float(costs[k]), self.row_classes[k][0], len(phones)
        return Naming(best_c, best_r, chance_threshold(best_n) if best_c else 0.0)


@lru_cache(maxsize=64)
def namer(classes: tuple[str, ...], lexicon: Lexicon | None = None) -> Namer:
    """The :class:`Namer` of a world's classes, built once."""
    return Namer(classes, lexicon)


def _slot_naming(reading: Reading, slot: Slot, nm: Namer) -> Naming:
    return _name_cached(tuple(reading.words[i] for i in slot.nouns), nm)


@lru_cache(maxsize=16384)
def _name_cached(words: tuple[str, ...], nm: Namer) -> Naming:
    return nm.name(words)


def object_targets(reading: Reading, nm: Namer) -> tuple[Slot, ...]:
    """The target slots that are object mentions: a slot that names an object (of the world, or
    a name the lexicon knows), or a noun phrase whose object was lost or misheard ("the ...",
    "the silver"). Words that name nothing and stand bare ("skip", "go", "chance" in "any chance
    you could ...") are background, as is a noun phrase naming nothing beside a target that names
    an object ("the rice, when you get a chance")."""
    targets = reading.targets
    if not targets:
        return ()
    naming = [_slot_naming(reading, s, nm) for s in targets]
    names = [n.near or bool(n.named) for n in naming]
    # a noun phrase that names nothing is background beside one that names an object; bare words
    # that name nothing are background beside any other slot
    phrases = [s for s, ok in zip(targets, names, strict=True) if ok or not reading.bare(s)]
    kept = tuple(s for s, ok in zip(targets, names, strict=True)
                 if ok or not s.nouns or (not any(names) and (not reading.bare(s) or not phrases)))
    return kept


def focus_text(text: str, focus: int | None, nm: Namer) -> str:
    """The words of ``text`` that ask for its object target ``focus`` (None: every one)."""
    reading = read(text)
    return reading.focus(focus, object_targets(reading, nm))


def target_positions(words: Sequence[str], focus: int | None, nm: Namer) -> frozenset[int] | None:
    """Word positions of the object target(s) of a transcript; None when it names none."""
    reading = read(" ".join(words))
    if tuple(reading.words) != tuple(words):
        return None
    targets = object_targets(reading, nm)
    if not targets:
        return None
    if focus is not None:
        targets = (targets[min(focus, len(targets) - 1)],)
    return frozenset(i for s in targets for i in range(s.start, s.end))


SLOTS = ("names", "far", "lost", "negated", "context", "empty")
CELLS = tuple(f"{f}{k}" for f in ("frame+", "frame-") for k in SLOTS)


@dataclass(frozen=True)
class Channel:
    """How the words of one kind of recogniser arise under each hypothesis (module doc): for every
    cell (a request frame or none, crossed with what the target slots do), (P(cell | request),
    P(cell | nobody asked)).

    ``open``: typed text and recognisers that write any word (Whisper, pocketsphinx with its
    general model). ``scene``: a recogniser that can only write the scene's command phrasings
    (``Instruction.scene_words``): it writes a frame and an object's name into any speech, so
    those cells say less about whether anybody asked (docs/understanding.md, "Channels").
    """

    name: str
    cells: tuple[tuple[str, float, float], ...]
    # the cells describe the words as said (stated: "open"), not a recogniser's outputs with its
    # errors in them (counted on them: "scene"); see :func:`_weigh`
    as_said: bool = True

    def __post_init__(self) -> None:
        got = {c for c, _, _ in self.cells}
        if got != set(CELLS):
            raise ValueError(f"channel {self.name!r} must give every cell of {CELLS}; missing {set(CELLS) - got}")
        for total in (sum(p1 for _, p1, _ in self.cells), sum(p0 for _, _, p0 in self.cells)):
            if abs(total - 1.0) > 1e-6:
                raise ValueError(f"channel {self.name!r}: the cells' probabilities sum to {total}, not 1")

    def log_probs(self, cell: str) -> tuple[float, float]:
        """(log P(cell | request), log P(cell | nobody asked))."""
        for c, p1, p0 in self.cells:
            if c == cell:
                return math.log(p1), math.log(p0)
        raise KeyError(cell)


def _channel(name: str, request: dict[str, float], nobody: dict[str, float], as_said: bool = True) -> Channel:
    """A channel from the two distributions over :data:`CELLS`."""
    def fill(d: dict[str, float]) -> dict[str, float]:
        missing = set(CELLS) - set(d)
        if missing:
            raise ValueError(f"channel {name!r} must give every cell of {CELLS}; missing {sorted(missing)}")
        total = sum(d.values())
        return {c: d[c] / total for c in CELLS}  # stated to a few digits: normalised

    r, n = fill(request), fill(nobody)
    return Channel(name, tuple((c, r[c], n[c]) for c in CELLS), as_said)


# How people speak (docs/understanding.md, "Channels"): (P(cell | request), P(cell | nobody asked)).
# A request has a frame ("could you", "pass me", "I need", "please") and names its object; a bare
# object ("the cereal") less often; an object the listener has no name for, or one lost ("could
# you get me the ..."), now and then. Nobody asks in thanks and room talk ("the weather is nice":
# a copula's subject, context), statements of what is here ("I already have the sugar"), and
# negations ("don't bring the tea": a frame whose only slot is negated). Stated, not fitted.
OPEN_CELLS: dict[str, tuple[float, float]] = {
    "frame+names": (0.78, 0.01), "frame+far": (0.04, 0.005), "frame+lost": (0.05, 0.002),
    "frame+negated": (0.004, 0.18), "frame+context": (0.004, 0.02), "frame+empty": (0.008, 0.023),
    "frame-names": (0.08, 0.02), "frame-far": (0.01, 0.10), "frame-lost": (0.01, 0.02),
    "frame-negated": (0.002, 0.05), "frame-context": (0.004, 0.25), "frame-empty": (0.002, 0.30),
}
# a recogniser that writes only the scene's phrasings: its first hypothesis's cells counted on the
# dev set's recordings (clean and 10 dB, 239 requests and 60 utterances that asked nothing, add
# one half per cell; docs/understanding.md, "Channels"): it writes a frame and an object's name
# into any speech, so only their absence says much
SCENE_CELLS: dict[str, tuple[float, float]] = {
    "frame+names": (0.745, 0.402), "frame+far": (0.002, 0.008), "frame+lost": (0.059, 0.144),
    "frame+negated": (0.002, 0.008), "frame+context": (0.002, 0.008), "frame+empty": (0.022, 0.189),
    "frame-names": (0.100, 0.144), "frame-far": (0.002, 0.008), "frame-lost": (0.010, 0.023),
    "frame-negated": (0.002, 0.008), "frame-context": (0.027, 0.008), "frame-empty": (0.027, 0.053),
}
OPEN = _channel("open", {c: p[0] for c, p in OPEN_CELLS.items()}, {c: p[1] for c, p in OPEN_CELLS.items()})
SCENE = _channel("scene", {c: p[0] for c, p in SCENE_CELLS.items()}, {c: p[1] for c, p in SCENE_CELLS.items()},
                 as_said=False)


def cue_cell(reading: Reading, nm: Namer) -> tuple[str, str]:
    """The cell of a reading (:data:`CELLS`) and, where it speaks against a request, why."""
    targets = object_targets(reading, nm)
    # a repair ("no, not the butter, the bacon") asks as a frame does
    repair = bool(targets) and any(s.role in ("negated", "retracted") for s in reading.slots)
    frame = "frame+" if reading.frame or repair else "frame-"
    if not targets:
        roles = {s.role for s in reading.slots}
        slot = ("negated" if roles & {"negated", "retracted"} else "context" if "context" in roles else "empty")
        return frame + slot, "no object was asked for"
    namings = [_slot_naming(reading, s, nm) for s in targets]
    if any(n.near or n.named for n in namings):
        return frame + "names", ""
    if any(not s.nouns for s in targets):
        return frame + "lost", ""
    words = " ".join(reading.slot_words(s) for s in targets)
    return frame + "far", f"{words!r} names no object here"


def _cue_log_probs(reading: Reading, nm: Namer, ch: Channel) -> tuple[float, float, str]:
    """(log P(cues | request), log P(cues | nobody asked), the cue that spoke against a request)."""
    cell, why = cue_cell(reading, nm)
    l1, l0 = ch.log_probs(cell)
    return l1, l0, why


@dataclass(frozen=True)
class Hearing:
    """One recogniser's words as evidence: its hypotheses with their weights (summing to 1), the
    channel they came through and how far its reading is to be trusted (``reliability`` in
    [0, 1]: 1 for typed text, Whisper's own confidence for its transcript)."""

    texts: tuple[str, ...]
    weights: tuple[float, ...]
    channel: Channel = OPEN
    reliability: float = 1.0
    who: str = "the recogniser"


@dataclass(frozen=True)
class _Heard:
    hearing: Hearing
    readings: tuple[Reading, ...]
    llr: float  # log P(words | request) - log P(words | nobody asked), through the channel
    why: str
    # how far the words speak for a request, weighed by their reliability: which hearing's
    # reading the record holds (:func:`_speaker`)
    speaks: float


def _weigh(h: Hearing, nm: Namer) -> _Heard:
    readings = tuple(read(t) for t in h.texts)
    cues = [_cue_log_probs(r, nm, h.channel) for r in readings]
    w = [max(float(x), 1e-12) for x in h.weights]
    rel = min(1.0, max(0.0, h.reliability))
    said = (math.log(sum(wi * math.exp(c[0]) for wi, c in zip(w, cues, strict=True)))
            - math.log(sum(wi * math.exp(c[1]) for wi, c in zip(w, cues, strict=True))))
    if h.channel.as_said:
        # the words as said with probability rel, else misheard: words of some utterance, whose
        # cell is drawn as any utterance's is (the channel's cells mixed at the prior odds) and so
        # speaks for neither hypothesis. P(cell | H) = rel P(cell | H) + (1 - rel) P(cell): a
        # garbled transcript ("has me the beans" for "pass me the beans") cannot outweigh the rest
        p1 = p0 = 0.0
        for wi, (l1, l0, _) in zip(w, cues, strict=True):
            slip = (1.0 - rel) * (PRIOR_REQUEST * math.exp(l1) + (1.0 - PRIOR_REQUEST) * math.exp(l0))
            p1 += wi * (rel * math.exp(l1) + slip)
            p0 += wi * (rel * math.exp(l0) + slip)
        llr = math.log(p1 / p0) if p1 > 0.0 and p0 > 0.0 else 0.0
    else:
        # a channel counted on the recogniser's own outputs holds its errors already: a tempered
        # likelihood, the reliability the weight of its (correlated) hypotheses
        llr = rel * said
    return _Heard(h, readings, llr, cues[0][2], rel * said)


def make_channel(name: str, request: dict[str, float], nobody: dict[str, float], as_said: bool = True) -> Channel:
    """A channel from its two distributions over :data:`CELLS` (normalised; every cell given);
    ``as_said=False`` for cells counted on a recogniser's own outputs (:class:`Channel`)."""
    return _channel(name, request, nobody, as_said)


def hearing_log_odds(h: Hearing, classes: Sequence[str], lexicon: Lexicon | None = None) -> float:
    """What one hearing adds to log-odds(somebody asked) in :func:`understand_heard`."""
    return _weigh(h, namer(tuple(classes), lexicon)).llr


def understand(texts: Sequence[str], weights: Sequence[float], classes: Sequence[str],
               lexicon: Lexicon | None = None) -> Understanding:
    """The understanding of what was heard: ``texts`` (N-best hypotheses or a transcript) with
    their weights (summing to 1), read against a world's ``classes``."""
    if not texts:
        return Understanding(False, 0.0, (), "", "nothing was heard")
    return understand_heard([Hearing(tuple(texts), tuple(float(w) for w in weights))], classes, lexicon)


def understand_heard(hearings: Sequence[Hearing], classes: Sequence[str],
                     lexicon: Lexicon | None = None) -> Understanding:
    """The understanding of one utterance from every recogniser that heard it (module doc).

    Each hearing is evidence for or against "somebody asked": with even prior odds,

        log-odds(request | all words) = sum_e r_e * log [ sum_n w_en P(cues_en | request)
                                                          / sum_n w_en P(cues_en | nobody asked) ]

    over recognisers e (reliability r_e, hypotheses n with weights w_en), the recognisers
    independent given the hypothesis. No one transcript decides: a garbled Whisper transcript of
    low confidence is outweighed by an N-best that holds the request word for word, and room
    talk Whisper heard clearly outweighs the command words a scene recogniser writes into it.
    The record's slots are read from the hearing that speaks most for the verdict."""
    hearings = [h for h in hearings if h.texts]
    if not hearings:
        return Understanding(False, 0.0, (), "", "nothing was heard")
    nm = namer(tuple(classes), lexicon)
    heard = [_weigh(h, nm) for h in hearings]
    lo = math.log(PRIOR_REQUEST / (1 - PRIOR_REQUEST)) + sum(x.llr for x in heard)
    p = 1.0 / (1.0 + math.exp(-max(-700.0, min(700.0, lo))))
    request = bool(p > 0.5)
    by = _speaker(heard, nm, request)
    reading = by.readings[0]
    mentions = []
    objects = set(object_targets(reading, nm))
    for s in reading.slots:
        if s.role == "target" and s not in objects:
            continue  # background words
        n = _slot_naming(reading, s, nm)
        mentions.append(Mention(s.role, reading.slot_words(s), n.obj_class if n.near else None, s.count, n.named))
    words = " ".join(reading.words)
    if request:
        said = ", ".join(_say(m) for m in mentions if m.role == "target")
        reason = f"asked for {said}" if said else "asked for something"
    else:
        reason = by.why or ("the words hold no request" if reading.words else "nothing was heard")
    return Understanding(request, float(p), tuple(mentions), words, reason)


def _speaker(heard: Sequence[_Heard], nm: Namer, request: bool) -> _Heard:
    """The hearing whose reading the record holds: of a request, the one that speaks most for it
    among those that hold an object slot (a lost object counts); else the one most against."""
    if not request:
        return min(heard, key=lambda x: x.speaks)
    with_slot = [x for x in heard if object_targets(x.readings[0], nm)]
    return max(with_slot or heard, key=lambda x: x.speaks)


def _say(m: Mention) -> str:
    what = m.obj_class or (m.named and f"{m.named} (not here)") or (m.words and f"{m.words!r}") or "an object not heard"
    return f"{m.count} x {what}" if m.count else str(what)


# The slot channel: how unlike a command's object the words of the target slot sound. Command k
# loses SLOT_SHARPNESS * max(0, r_k - SLOT_SLACK) nats (at most SLOT_CAP), r_k the relative
# phoneme cost of the slot's words against k's names (Namer.costs: 0 for k's own name, ~0.35 for
# a rhyme such as "potato" for "tomato", 0.5 and more for words nothing alike). A recogniser
# confuses near rhymes, so they cost little and the person's actions can still choose ("potato"
# heard, the salad under way: the tomato); it does not write "beans" for "bowl", so an object
# named clearly wins against the plan (docs/understanding.md).
SLOT_SHARPNESS = 30.0
# a recogniser that can only write the scene's phrasings (``Instruction.scene_words``) writes some
# object's name whatever was said: its names speak with this share of the sharpness and the cap
SCENE_WORDS_WEIGHT = 0.25
SLOT_SLACK = 0.3
SLOT_CAP = 12.0


@lru_cache(maxsize=65536)
def phone_distance(a: str, b: str) -> float:
    """The phoneme edit distance of two words (unit costs) over the longer one's length: 0 for
    the same sounds, 1/3 for "potato" and "tomato", 1/2 for "beans" and "bowls", 1 for nothing
    shared. The recogniser's confusions are between words this near (docs/understanding.md)."""
    pa = tuple(p for w in a.split() for p in word_phonemes(w))
    pb = tuple(p for w in b.split() for p in word_phonemes(w))
    if not pa or not pb:
        return 0.0 if pa == pb else 1.0
    from siftom.speech.metrics import edit_distance

    return edit_distance(pa, pb) / max(len(pa), len(pb))


def _target_slots(reading: Reading, focus: int | None, nm: Namer) -> tuple[Slot, ...]:
    targets = object_targets(reading, nm)
    if focus is not None and targets:
        targets = (targets[min(focus, len(targets) - 1)],)
    return targets


@lru_cache(maxsize=16384)
def _slot_costs(words: tuple[str, ...], nm: Namer) -> tuple[float, ...]:
    return tuple(nm.costs(words))


def _count_cost(said: int, count: int) -> float:
    """r between two counts' number words (0 when equal)."""
    from siftom.likelihood.numbers import number_word

    if said == count:
        return 0.0
    return phone_distance(number_word(said), number_word(count))


def slot_log_factor(texts: Sequence[str], weights: Any, commands: Sequence[Any], lexicon: Lexicon | None,
                    focus: int | None, sharpness: float = SLOT_SHARPNESS, cap: float = SLOT_CAP) -> Any:
    """Per command k: log sum_n w_n exp(-penalty_n(k)), the slot channel (module constants):
    for hypothesis n, the penalty of k's object against the target slot's words, plus that of
    k's count against the count said. A hypothesis with no target words contributes w_n to every
    command (the slot was lost: it says nothing). ``weights`` w_n sum to 1."""
    import numpy as np

    classes = tuple(sorted({c.obj_class for c in commands}))
    # the slot is read against every class the lexicon knows and the commands', so a command's
    # factor does not depend on which other commands are scored with it
    known = tuple(sorted(set(classes) | set((lexicon or default_lexicon()).classes)))
    nm = namer(known, lexicon)
    col = {c: k for k, c in enumerate(nm.classes)}
    idx = np.array([col[c.obj_class] for c in commands])
    counts = [int(c.count) for c in commands]
    mix = np.zeros(len(commands))
    for text, w in zip(texts, weights, strict=True):
        reading = read(text)
        slots = [s for s in _target_slots(reading, focus, nm) if s.nouns]
        if not slots or sharpness <= 0:
            mix += float(w)
            continue
        best = np.full(len(commands), np.inf)
        for s in slots:  # with every target at once (focus None): the nearest slot speaks for k
            r = np.asarray(_slot_costs(tuple(reading.words[i] for i in s.nouns), nm))
            # each hypothesis points to the objects it sounds like, the nearest object the lexicon
            # knows at no cost: one that matches nothing exactly ("see real") weighs as much as
            # one that names an object
            pen = sharpness * np.maximum(0.0, r - SLOT_SLACK)
            pen = np.minimum(pen - pen.min(), cap)[idx]
            if s.count is not None:
                # the count said picks among the counts of one object, never another object: more
                # than the world holds ("two cups" where a fetch carries one, "three mugs" where
                # two are left) is the object asked for, beyond its supply
                cc = sharpness * np.array([max(0.0, _count_cost(s.count, n) - SLOT_SLACK) for n in counts])
                least = np.full(len(nm.classes), np.inf)
                np.minimum.at(least, idx, cc)
                pen = pen + cc - least[idx]
            best = np.minimum(best, pen)
        mix += float(w) * np.exp(-np.minimum(best, cap))
    return np.log(np.maximum(mix, 1e-300))
