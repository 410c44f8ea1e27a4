"""Reading a reply's words against the open question (docs/decisions.md, "Replies"): each
hypothesis of what was heard read by the utterance model, an answer or room talk weighed
(:mod:`siftom.assist.reply` says how), and the reply's factor per command.
:mod:`siftom.assist.reply` re-exports every public name here."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from siftom.assist.questions import (
    NO_KEYS,
    ORDINAL_KEYS,
    OTHER_KEYS,
    REFUSE_ALL_KEYS,
    YES_KEYS,
    Question,
    channel,
)
from siftom.errors import CommandParseError
from siftom.inference.model import Posterior
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

# P(cue | an answer to the question), P(cue | room talk): each ratio's two probabilities
# the words name a cell of the question or say an answer word ("yes", "neither", "the other
# one", an option, "not the cheese"): most answers do; room talk only by chance (asking for
# another object is a request, which the utterance model weighs, not an answer word)
P_CELL = (0.90, 0.10)
# each word outside the answer's vocabulary (the question's answer words, object names, the
# grammar's function words): the count is geometric with these ratios, so answers average 0.1
# such words and room talk 4 ("the weather is really nice today": weather, is, nice, today)
P_EXTRA = (0.10, 0.80)
PRIOR_ANSWER = 0.5  # an utterance after a question is as likely its answer as anything else
# "not the cheese" to "Which one: the cheese or the plate?" most often means the plate: a
# person who wants neither option says "neither" or names what they want; P(a refusal of one
# option | neither) against P(it | the other option)
REFUSAL_OTHER = 0.25
# the grammar's word classes an answer is made of besides its own words and object names:
# determiners, counts, negations and corrections, "please", fillers, "and", and the words of a
# request frame ("no, I need the milk", "could you get the flour")
ANSWER_KINDS = frozenset({"DET", "NUM", "NEG", "MEAN", "PLEASE", "FILLER", "AND", "VERB", "ME", "MODAL", "YOU",
                          "SELF", "WANT"})


@dataclass(frozen=True)
class HeardAnswer:
    """One hypothesis of what was heard, read as an answer to the question.

    Attributes:
        text: the words.
        weight: the hypothesis's weight among those heard (they sum to 1).
        p_answer: P(the words answer the question | the words), against room talk.
        cells: per cell of the question, P(the words | the person meant that cell) up to a
            constant ("not the cheese": 0 for the cheese, 1 for the plate, :data:`REFUSAL_OTHER`
            for anything else); None when they name no cell.
        refused: the options the words refuse.
        named: the options the words ask for by name.
        why: what was read, one line.
    """

    text: str
    weight: float
    p_answer: float
    cells: tuple[float, ...] | None
    refused: frozenset[str]
    named: frozenset[str]
    why: str


@dataclass(frozen=True)
class ReplyReading:
    """What a reply says to the question, from every hypothesis of what was heard (:mod:`siftom.assist.reply`)."""

    question: Question
    hypotheses: tuple[HeardAnswer, ...]

    @property
    def p_answer(self) -> float:
        """P(the words answer the open question | what was heard)."""
        return float(sum(h.weight * h.p_answer for h in self.hypotheses))

    @property
    def answers(self) -> bool:
        return self.p_answer > 0.5

    def p_refused(self, option: str) -> float:
        """P(the reply refuses ``option``)."""
        return float(sum(h.weight * h.p_answer for h in self.hypotheses if option in h.refused))

    @property
    def refused(self) -> tuple[str, ...]:
        """The options refused with probability over one half (in the question's order)."""
        return tuple(o for o in self.question.options if self.p_refused(o) > 0.5)

    @property
    def named(self) -> tuple[str, ...]:
        """The options asked for by name with probability over one half."""
        return tuple(o for o in self.question.options
                     if sum(h.weight * h.p_answer for h in self.hypotheses if o in h.named) > 0.5)

    @property
    def cell(self) -> int | None:
        """The one cell the most probable answer names (None: it allows several, or none)."""
        best = max(self.hypotheses, key=lambda h: h.weight * h.p_answer, default=None)
        if best is None or best.p_answer <= 0.5 or best.cells is None:
            return None
        top = max(best.cells)
        return best.cells.index(top) if top > 0 and best.cells.count(top) == 1 else None

    def log_lik(self, commands: Sequence[str], prior: np.ndarray, r: float) -> np.ndarray:
        """log P(reply | c) per command up to a constant (:mod:`siftom.assist.reply`): ``prior`` P(c) before the
        reply, ``r`` the kind's reliability (the channel of assist/questions.py)."""
        q = self.question
        conf = channel(q.n_cells, r)
        cell_of = np.array([q.cell(str(c)) for c in commands], dtype=int)
        p = np.asarray(prior, dtype=np.float64)
        total = np.zeros(len(commands))
        for h in self.hypotheses:
            lik = np.ones(len(commands))
            if h.cells is not None:
                heard = (np.asarray(h.cells) @ conf)[cell_of]  # sum_j P(words | j) P(heard j | c's cell)
                z = float(p @ heard)
                lik = heard / z if z > 0 else lik
            total += h.weight * (h.p_answer * lik + (1.0 - h.p_answer))
        out: np.ndarray = np.log(np.maximum(total, 1e-300))
        out -= out.max()
        return out

    def to_json(self) -> dict[str, Any]:
        return {"p_answer": round(self.p_answer, 6), "cell": self.cell, "refused": list(self.refused),
                "named": list(self.named),
                "heard": [{"text": h.text, "weight": round(h.weight, 6), "p_answer": round(h.p_answer, 6),
                           "why": h.why} for h in self.hypotheses]}


def _llr(p: tuple[float, float]) -> float:
    return math.log(p[0] / p[1])


def _parse_command(command: str) -> RobotCommand | None:
    try:
        return RobotCommand.parse(command)
    except CommandParseError:
        return None


def _reply_words(question: Question) -> frozenset[str]:
    """The words that answer without naming an object: the keys of the question's "anything
    else" cell ("neither", "nothing") and the yes / no / "the other one" / "the first one" words."""
    return frozenset(set(question.keys[-1]) | set(YES_KEYS) | set(NO_KEYS) | set(REFUSE_ALL_KEYS) | set(OTHER_KEYS)
                     | set(ORDINAL_KEYS))


def _answer_vocabulary(question: Question) -> frozenset[str]:
    """Every word of the question's answer grammar (its phrases and keys)."""
    words = {w for phrase in question.grammar() for w in phrase.lower().replace(",", " ").split()}
    return frozenset(words | _reply_words(question))


def _slot_matcher(words: Sequence[str], nm: Any, parsed: dict[str, RobotCommand | None], option_classes: set[str],
                  reply_words: frozenset[str]) -> Callable[[Any], tuple[set[str], bool, bool]]:
    """What a slot of the reply's reading names among the options (:func:`read_answer`)."""
    # "the other one", "the second one": "one" stands for an option, it is no count
    pronoun_one = any(w in OTHER_KEYS or w in ORDINAL_KEYS for w in words)

    def matching(slot: Any) -> tuple[set[str], bool, bool]:
        """(options the slot names, whether it names another object, whether it names anything)."""
        nouns = tuple(words[i] for i in slot.nouns if words[i] not in reply_words)
        count = None if pronoun_one and slot.count == 1 else slot.count
        cls = None
        if nouns:
            naming = nm.name(nouns)
            if naming.near:
                cls = naming.obj_class
            elif naming.named:
                return set(), True, True  # a known object the world lacks: something else
        if cls is not None:
            cands = {o for o, p in parsed.items() if p is not None and p.obj_class == cls}
            if count is not None and len({p.count for o in cands if (p := parsed[o]) is not None}) > 1:
                cands = {o for o in cands if (p := parsed[o]) is not None and p.count == count}
            return cands, cls not in option_classes, True
        if count is not None:
            counts = {o: p.count for o, p in parsed.items() if p is not None}
            cands = {o for o, n in counts.items() if n == count}
            if cands and len(cands) < len(counts):
                return cands, False, True
        return set(), False, False

    return matching


def _intent(question: Question, named: set[str], negated: set[str], other_named: bool, unnamed: bool,
            said: tuple[bool, bool, bool, bool]) -> tuple[dict[int, float] | None, str, bool]:
    """(P(the words | the person meant cell j) per cell named, None for none; why; whether the
    words refuse every option) from what the reply names and refuses and whether it says yes,
    no, neither or "the other one" (``said``)."""
    yes, no, neither, other_one = said
    other = question.n_cells - 1
    only = {other: 1.0}
    if named - negated:
        return {question.cell(o): 1.0 for o in named - negated}, "names " + ", ".join(sorted(named - negated)), False
    if other_named:  # "none of those, I need the milk" refuses every option
        return only, "asks for something else", neither
    if negated and unnamed:
        return only, "refuses " + ", ".join(sorted(negated)) + " and asks for something else", False
    if negated:
        out = {question.cell(o) for o in negated}
        intent = {k: (REFUSAL_OTHER if k == other and question.kind != "confirm" else 1.0)
                  for k in range(question.n_cells) if k not in out}
        return intent, "refuses " + ", ".join(sorted(negated)), False
    if neither or (no and question.kind != "confirm"):
        return only, "refuses every option", True
    if yes and question.kind == "confirm":
        return {0: 1.0}, "says yes", False
    if (no or other_one) and question.kind == "confirm":
        return only, "says no", True
    return None, "names no option", False


def read_answer(question: Question, text: str, nm: Any) -> tuple[float, tuple[float, ...] | None, frozenset[str],
                                                                  frozenset[str], str]:
    """One hypothesis read against ``question`` by the utterance model (:mod:`siftom.assist.reply`):
    (log-odds it answers the question, P(the words | the person meant cell j) per cell up to a
    constant or None when they name no cell, the options it refuses, the options it names, why).
    ``nm``: the world's :class:`~siftom.language.understand.Namer`."""
    from siftom.language.parse import read

    reading = read(text)
    words, kinds = reading.words, reading.kinds
    options = question.options
    parsed = {o: _parse_command(o) for o in options}
    option_classes = {p.obj_class for p in parsed.values() if p is not None}
    reply_words = _reply_words(question)
    vocabulary = _answer_vocabulary(question)
    matching = _slot_matcher(words, nm, parsed, option_classes, reply_words)

    named: set[str] = set()
    negated: set[str] = set()
    other_named = False
    unnamed = False
    negated_nothing = False  # "not that one"
    named_positions: set[int] = set()
    for slot in reading.slots:
        if slot.role == "context":
            continue
        got, elsewhere, names = matching(slot)
        if names:
            named_positions.update(range(slot.start, slot.end))
        if slot.role == "target":
            named |= got
            other_named = other_named or (elsewhere and not got)
            # a noun phrase naming nothing here: an object all the same, misheard ("not the
            # tomato, the indian" for "the onion"): something else than the options
            unnamed = unnamed or (not names and any(words[i] not in reply_words for i in slot.nouns)
                                  and not reading.bare(slot))
        elif slot.role == "negated":
            negated |= got
            negated_nothing = negated_nothing or not names
        # a retracted slot ("the cereal, I mean the flour"): taken back, neither named nor refused
    in_negated = {i for s in reading.slots if s.role == "negated" for i in range(s.start, s.end)}
    if question.kind == "choose":  # "the first one", "not the second one": an option by its place
        for i, w in enumerate(words):
            if w in ORDINAL_KEYS:
                (negated if i in in_negated else named).add(options[ORDINAL_KEYS[w]])
    said = [w for i, w in enumerate(words) if i not in in_negated]
    yes = any(w in YES_KEYS for w in said)
    # "neither" to "Shall I get the sugar?" refuses the one option offered: a "no"
    no = any(w in NO_KEYS or (question.kind == "confirm" and w in REFUSE_ALL_KEYS) for w in said) or negated_nothing
    neither = any(w in question.keys[-1] for w in said)
    other_one = any(w in OTHER_KEYS for w in said)
    intent, why, refuses_all = _intent(question, named, negated, other_named, unnamed,
                                       (yes, no, neither, other_one))
    refused: set[str] = set(negated) | (set(options) if refuses_all else set())
    cells = None if intent is None else tuple(intent.get(k, 0.0) for k in range(question.n_cells))
    refused -= named - negated
    # asking for another object is a request (the utterance model weighs that), not an answer word
    answer_word = (intent is not None and not (other_named and not named)) or yes or no or neither or other_one
    extra = sum(1 for i, (w, kind) in enumerate(zip(words, kinds, strict=True))
                if w not in vocabulary and i not in named_positions and kind not in ANSWER_KINDS)
    lo = math.log(PRIOR_ANSWER / (1 - PRIOR_ANSWER))
    lo += _llr(P_CELL) if answer_word else _llr((1 - P_CELL[0], 1 - P_CELL[1]))
    lo += math.log((1 - P_EXTRA[0]) / (1 - P_EXTRA[1])) + extra * _llr(P_EXTRA)
    if extra:
        why += f"; {extra} word{'s' if extra > 1 else ''} outside the answer's"
    return lo, cells, frozenset(str(o) for o in refused), frozenset(str(o) for o in named - negated), why


def heard_after(question: Question, instruction: Instruction, likelihood: Any) -> tuple[str, float] | None:
    """Whisper's words for a recorded reply, transcribed with the robot's question as the text
    before it (Whisper's prompt), and their mean token log-probability; None without a recording
    or a Whisper model in ``likelihood`` (the acoustic likelihood's own).

    After a question the conversation is the question: with the scene's object names as the
    prompt, Whisper tiny.en wrote "not the cheese" as "nut the cheese", "no" as "nove" and
    "neither" as nothing; with the question it writes them as said, and room talk as said."""
    factor = getattr(likelihood, "_whisper", None)
    if factor is None or not instruction.has_audio:
        return None
    from siftom.speech.audio import as_audio

    x = instruction.samples if instruction.samples is not None else (
        as_audio(instruction.audio) if instruction.audio is not None else None)
    if x is None or not len(x):
        return None
    from siftom.errors import SiftomError

    try:
        scorer = factor.scorer
        words, logprob = scorer.hear_encoded(scorer.encode(x), prompt=question.text)
    except SiftomError:  # a clip Whisper cannot take: the reply is read from the other words heard
        return None
    return " ".join(words), float(logprob)


def reply_texts(instruction: Instruction, post: Posterior | None = None,
                after: tuple[str, float] | None = None) -> tuple[list[str], list[float]]:
    """The hypotheses of what was heard and their weights, as the utterance model reads them:
    Whisper's words for the reply (``after``, :func:`heard_after`) when it heard some and its
    decoding did not fail (Whisper's own ``logprob_threshold``); else Whisper's words of the
    request path (``post``'s understanding says whose words it read); else the N-best with its
    weights (``siftom.inference.understood``)."""
    from siftom.likelihood.nearness import ASR_TEMPERATURE, MIN_WEIGHT
    from siftom.speech.whisper_score import LOGPROB_THRESHOLD

    if after is not None and after[0].strip() and after[1] >= LOGPROB_THRESHOLD:
        return [after[0]], [1.0]
    u = post.understanding if post is not None else None
    if post is not None and post.evidence.get("instruction_check") == "whisper" and u is not None and u.heard:
        return [u.heard], [1.0]
    hyps = [h for h in instruction.nbest if h.text.strip()]
    if not hyps:
        return [], []
    sc = np.array([float(h.score) for h in hyps]) / ASR_TEMPERATURE
    w = np.exp(sc - sc.max())
    w /= w.sum()
    floor = min(MIN_WEIGHT, float(w.max()))
    keep = [k for k in range(len(hyps)) if w[k] >= floor]
    total = float(w[keep].sum())
    return [hyps[k].text for k in keep], [float(w[k]) / total for k in keep]


def read_reply(question: Question, texts: Sequence[str], weights: Sequence[float], classes: Sequence[str],
               lexicon: Any = None) -> ReplyReading:
    """The reading of a reply to ``question``: each of ``texts`` (weights summing to 1) read
    against the world's ``classes`` (``lexicon``: the world's names; None: the built-in one)."""
    from siftom.language.understand import namer

    own = {p.obj_class for o in question.options if (p := _parse_command(o)) is not None}
    nm = namer(tuple(sorted(set(classes) | own)), lexicon)
    hyps = []
    for text, w in zip(texts, weights, strict=True):
        lo, cells, refused, named, why = read_answer(question, text, nm)
        hyps.append(HeardAnswer(text, float(w), 1.0 / (1.0 + math.exp(-lo)), cells, refused, named, why))
    return ReplyReading(question, tuple(hyps))


def cell_named(question: Question, instruction: Instruction, classes: Sequence[str] = (),
               lexicon: Any = None) -> int | None:
    """The one cell of ``question`` the reply names (:attr:`ReplyReading.cell`): read by the
    utterance model, negation included, against ``classes`` (default: the options' own)."""
    texts, weights = reply_texts(instruction)
    return read_reply(question, texts, weights, classes, lexicon).cell
