"""Robot commands: the robot's part of the joint plan, pi_r (paper, Methods).

A command asks the robot to bring ``count`` items of one object class to the human's
work place (the dining table in the household domain, the kitchen counter in the kitchen
domain). Written ``deliver(fork,3)`` or ``fetch(cereal)`` (count 1).
"""

from __future__ import annotations

import re

from siftom.errors import CommandParseError

VERBS = ("deliver", "fetch")
MAX_COUNT = 4  # the largest count a command asks for: the command space is COUNT in 1..MAX_COUNT
_COMMAND_RE = re.compile(r"^\s*(\w+)\s*\(\s*([A-Za-z_][\w]*)\s*(?:,\s*(\d+)\s*)?\)\s*$")
VALID_FORMS = "deliver(CLASS,COUNT), e.g. deliver(fork,3); fetch(CLASS) or fetch(CLASS,COUNT), e.g. fetch(cereal)"


class RobotCommand(str):
    """Bring ``count`` objects of class ``obj_class`` to the human's work place.

    A command is its written form (``fetch(tomato)``, ``deliver(fork,3)``): it is a ``str``, so it
    compares, hashes and serialises as that text, and it carries ``verb``, ``obj_class`` and
    ``count`` as attributes. Immutable.
    """

    verb: str
    obj_class: str
    count: int  # type: ignore[assignment]  # the number of objects, in place of str.count

    def __new__(cls, verb: str, obj_class: str, count: int = 1) -> RobotCommand:
        if verb not in VERBS:
            raise CommandParseError(f"unknown verb {verb!r}; valid forms: {VALID_FORMS}")
        if not isinstance(count, int) or count < 1:
            raise CommandParseError(f"count must be >= 1, got {count}; valid forms: {VALID_FORMS}")
        text = f"fetch({obj_class})" if verb == "fetch" and count == 1 else f"{verb}({obj_class},{count})"
        self = super().__new__(cls, text)
        object.__setattr__(self, "verb", verb)
        object.__setattr__(self, "obj_class", obj_class)
        object.__setattr__(self, "count", count)
        return self

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"RobotCommand is immutable; make a new one instead of setting {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("RobotCommand is immutable")

    def __getnewargs__(self) -> tuple[str, str, int]:  # type: ignore[override]
        return (self.verb, self.obj_class, self.count)

    def __str__(self) -> str:
        return str.__str__(self)

    def __repr__(self) -> str:
        return f"RobotCommand({self.verb!r}, {self.obj_class!r}, {self.count})"

    @classmethod
    def parse(cls, text: str) -> RobotCommand:
        """Parse ``deliver(fork,3)`` / ``fetch(cereal)``; raise CommandParseError otherwise."""
        if not isinstance(text, str):
            raise CommandParseError(f"a command must be a string; valid forms: {VALID_FORMS}")
        m = _COMMAND_RE.match(text)
        if not m:
            raise CommandParseError(f"cannot parse command {text!r}; valid forms: {VALID_FORMS}")
        verb, obj, count = m.group(1).lower(), m.group(2).lower(), m.group(3)
        return cls(verb, obj, int(count) if count else 1)
