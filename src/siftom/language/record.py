"""What was understood from what was heard: one typed record at every door.

An :class:`Understanding` is the utterance model's reading of the words (``siftom.language``):
whether anybody asked the robot for something (``request``, with its probability), the objects
asked for (``targets``, each with the count said), objects named as context ("for the cereal",
"the sugar is already here") and objects negated or taken back ("not the sugar", "the jam, I
mean the honey"). Only targets count for a command; every other word is background.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

ROLES = ("target", "context", "negated", "retracted")


@dataclass(frozen=True)
class Mention:
    """One object slot of an utterance.

    Attributes:
        role: ``target`` (asked for), ``context`` (named around the request), ``negated`` ("not
            the X", "don't bring the X") or ``retracted`` ("the X, I mean the Y": X).
        words: the heard words of the slot, without article or count ("sugar", "olive oil").
        obj_class: the class of the world the words name best (exactly or as heard), or None
            when they are near no class of the world.
        count: the count said ("four bowls": 4), None when none was said.
        named: the object the words name when it is not in the world (a known name such as
            "banana"), else ''.
    """

    role: str
    words: str
    obj_class: str | None = None
    count: int | None = None
    named: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"role": self.role, "words": self.words, "class": self.obj_class, "count": self.count,
                "named": self.named or None}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Mention:
        return cls(str(d["role"]), str(d["words"]), d.get("class"), d.get("count"), d.get("named") or "")


@dataclass(frozen=True)
class Understanding:
    """The utterance model's reading of what was heard (module doc).

    Attributes:
        request: whether someone asked the robot for something (``p_request`` > 0.5).
        p_request: P(a request | words) against the "nobody asked" hypothesis.
        mentions: every object slot, in the order heard.
        heard: the words read (the recogniser's best hypothesis or the transcript).
        reason: one line a person can read: what was understood, or why it is no request.
    """

    request: bool
    p_request: float
    mentions: tuple[Mention, ...] = ()
    heard: str = ""
    reason: str = ""

    @property
    def targets(self) -> tuple[Mention, ...]:
        """The objects asked for, in the order heard."""
        return tuple(m for m in self.mentions if m.role == "target")

    @property
    def context(self) -> tuple[Mention, ...]:
        return tuple(m for m in self.mentions if m.role == "context")

    @property
    def negated(self) -> tuple[Mention, ...]:
        """Objects negated or taken back: not asked for."""
        return tuple(m for m in self.mentions if m.role in ("negated", "retracted"))

    def to_json(self) -> dict[str, Any]:
        return {"request": self.request, "p_request": round(self.p_request, 6),
                "targets": [m.to_json() for m in self.targets],
                "context": [m.to_json() for m in self.context],
                "negated": [m.to_json() for m in self.mentions if m.role == "negated"],
                "retracted": [m.to_json() for m in self.mentions if m.role == "retracted"],
                "heard": self.heard, "reason": self.reason}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Understanding:
        mentions = [Mention.from_json(m) for key in ("targets", "context", "negated", "retracted")
                    for m in d.get(key, [])]
        return cls(bool(d["request"]), float(d["p_request"]), tuple(mentions), str(d.get("heard", "")),
                   str(d.get("reason", "")))


NOBODY_ASKED = Understanding(False, 0.0, (), "", "nothing was said")
