"""Robot commands: the robot's part of the joint plan, pi_r (paper, Methods).

A command asks the robot to bring ``count`` items of one object class to the human's
work place (the dining table in the household domain, the kitchen counter in the kitchen
domain). Written ``deliver(fork,3)`` or ``fetch(cereal)`` (count 1).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from siftom.errors import CommandParseError

VERBS = ("deliver", "fetch")
MAX_COUNT = 4  # the largest count a command asks for: the command space is COUNT in 1..MAX_COUNT
_COMMAND_RE = re.compile(r"^\s*(\w+)\s*\(\s*([A-Za-z_][\w]*)\s*(?:,\s*(\d+)\s*)?\)\s*$")
VALID_FORMS = "deliver(CLASS,COUNT), e.g. deliver(fork,3); fetch(CLASS) or fetch(CLASS,COUNT), e.g. fetch(cereal)"


@dataclass(frozen=True, slots=True, order=True)
class RobotCommand:
    """Bring ``count`` objects of class ``obj_class`` to the human's work place."""

    verb: str
    obj_class: str
    count: int = 1

    def __post_init__(self) -> None:
        if self.verb not in VERBS:
            raise CommandParseError(f"unknown verb {self.verb!r}; valid forms: {VALID_FORMS}")
        if self.count < 1:
            raise CommandParseError(f"count must be >= 1, got {self.count}; valid forms: {VALID_FORMS}")

    def __str__(self) -> str:
        if self.verb == "fetch" and self.count == 1:
            return f"fetch({self.obj_class})"
        return f"{self.verb}({self.obj_class},{self.count})"

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
