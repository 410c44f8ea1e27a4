"""The words people use to take back, refuse or restate what they asked for, read before the
roles (``parse.py``): "no" that answers rather than quantifies, edit terms after a target, and a
noun's "'s" that is a copula."""

from __future__ import annotations

# determiners that cannot follow a quantifier "no": after "no" they start a new phrase, so the
# "no" answers or rejects what came before ("no, the flour"), it does not negate the slot
DEFINITE = frozenset({"the", "a", "an", "that", "this", "these", "those", "my", "your", "our"})
NEW_PHRASE = frozenset({"SELF", "YOU", "ME", "VERB", "MODAL", "PLEASE", "NEG", "MEAN", "FILLER", "WH"})


# where an object already is ("the onion's already chopped"): after a noun's "'s", a copula
HERE_WORDS = frozenset({"already", "here", "there", "done", "finished", "ready", "gone", "out"})


def uncontract(words: tuple[str, ...]) -> tuple[str, ...]:
    """``words`` with a noun's "'s" read as "is" where a statement of where it is follows ("the
    onion's already chopped": the onion is context, not a second object asked for)."""
    if not any(w.endswith("'s") for w in words):
        return words
    out: list[str] = []
    for k, w in enumerate(words):
        nxt = words[k + 1] if k + 1 < len(words) else ""
        if w.endswith("'s") and len(w) > 2 and nxt in HERE_WORDS and w not in CONTRACTED:
            out.extend((w[:-2], "is"))
        else:
            out.append(w)
    return tuple(out)


CONTRACTED = frozenset({"it's", "that's", "there's", "here's", "where's", "what's", "let's", "he's", "she's"})


def rejects(words: tuple[str, ...], kinds: tuple[str, ...], at: int) -> bool:
    """Whether the "no" at ``at`` answers or rejects what came before rather than negating the
    phrase after it. A quantifier "no" takes a noun or a count ("no sugar", "no more milk", "no
    need to bring the cup", "no two plates"); a "no" that starts a new phrase -- a definite
    determiner, a subject, a request, another negation, a filler, or nothing -- does not ("no,
    the flour", "no I need the oats", "no, bring the honey", "no, not the sugar", "no thanks")."""
    if words[at] != "no":
        return False
    if at + 1 >= len(words):
        return True
    nxt = kinds[at + 1]
    if nxt == "WORD" and at > 0 and kinds[at - 1] == "WORD" and (at < 2 or kinds[at - 2] not in ("CTX", "AND")):
        # right after an object's name, a bare "no" and another name restate it ("pasta, no, olive
        # oil"); a quantifier "no" follows a relation or a list ("with no garlic", "and no ice")
        return True
    return nxt in NEW_PHRASE or (nxt == "DET" and words[at + 1] in DEFINITE)


def repairs(words: tuple[str, ...], kinds: tuple[str, ...], at: int, kind: str) -> bool:
    """Whether the marker at ``at`` is an edit term after a target: a correction word, "never
    mind", or a "no" before a count ("three mugs, no, three cups": the count starts the repair,
    it does not quantify a negation)."""
    w = words[at]
    nxt = words[at + 1] if at + 1 < len(words) else ""
    if w == "never" and nxt == "mind":
        return True
    if w == "no" and at + 1 < len(kinds) and kinds[at + 1] == "NUM":
        return True
    return kind == "MEAN"


# verbs of omission: they refuse the object that follows them ("forget the milk", "leave the
# cereal", "skip the bowl")
VERB_NEG = frozenset({"forget", "leave", "skip"})
# hesitations between two objects asked for that leave them adjacent ("the carrot, uh, the onion")
HESITATIONS = frozenset({"um", "uh", "er", "erm", "hmm"})
# a phrase after an object that starts with one of these says whose or where, not which ("the
# plate my way"): no repair
POSSESSIVE = frozenset({"my", "your", "our"})
