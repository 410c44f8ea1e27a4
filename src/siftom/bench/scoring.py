"""Is a chosen command right? The evaluator's per-trial scores (no other bench module needed)."""

from __future__ import annotations

from collections.abc import Container


def is_correct(command: str, gold: str, verb: str) -> bool:
    """Object class and count exact (class only for ``fetch``); ``none`` is never correct."""
    if command == "none":
        return False
    from siftom.world.commands import RobotCommand

    c, g = RobotCommand.parse(command), RobotCommand.parse(gold)
    if verb == "fetch":
        return c.obj_class == g.obj_class
    return c.obj_class == g.obj_class and c.count == g.count


def is_helpful(command: str, goal_counts: Container[str]) -> bool:
    """A command whose class is part of the human's goal."""
    if command == "none":
        return False
    from siftom.world.commands import RobotCommand

    return RobotCommand.parse(command).obj_class in goal_counts
