"""What a user scene loads into, and the goals it may be asked for: a world's own goal list or
a named goal space (:mod:`siftom.world.io` reads the files)."""

from __future__ import annotations

import difflib
from collections import Counter
from dataclasses import dataclass
from typing import Any

from siftom.errors import ObservationError
from siftom.world.model import Goal, State, World


@dataclass(frozen=True, eq=False)
class LoadedScene:
    """A user scene: world, start state, goal space and the robot's verb."""

    world: World
    start: State
    goals: tuple[Goal, ...]
    verb: str
    notes: tuple[str, ...] = ()  # what the loader left out, and why (shown as warnings)


def _need(d: object, key: str, where: str) -> Any:
    if not isinstance(d, dict):
        raise ObservationError(f"{where} must be an object with {key!r}")
    if key not in d:
        raise ObservationError(f"{where}: missing {key!r}")
    return d[key]


@dataclass(frozen=True)
class GoalSpec:
    """Where a world's goals come from: its own ``goals`` (the JSON list as given, checked when the
    goals are read; None: it has none) or else the named ``goal_space``."""

    goal_space: str = "household-table-v0"
    goals: object = None

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> GoalSpec:
        """The ``goals`` and ``goal_space`` of world JSON (``"goals": null`` is an empty list, refused when read)."""
        space = obj.get("goal_space", "household-table-v0")
        if "goals" in obj:
            return cls(space, obj["goals"] if obj["goals"] is not None else [])
        return cls(space)


def goal_library(spec: GoalSpec, target: int) -> list[Goal]:
    """Every goal of the library a world names (its own ``goals`` or a ``goal_space``), unfiltered."""
    if spec.goals is not None:
        goals = []
        raw = spec.goals
        if not isinstance(raw, list) or not raw:
            raise ObservationError("goals must be a non-empty list like [{\"name\": \"salad\", \"counts\": {\"tomato\": 1}}]")
        for k, g in enumerate(raw):
            if not isinstance(g, dict):
                raise ObservationError(f"goals[{k}] must be an object with name and counts")
            counts = _need(g, "counts", f"goals[{k}]")
            if not isinstance(counts, dict) or not counts:
                raise ObservationError(f"goals[{k}]: counts must be an object like {{\"fork\": 2}}")
            if not all(isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 20 for n in counts.values()):
                raise ObservationError(f"goals[{k}]: each count must be an integer from 1 to 20")
            goals.append(Goal(str(g.get("name", f"goal{k}")), target, tuple(sorted((str(c), int(n)) for c, n in counts.items()))))
        return goals
    space = spec.goal_space
    if space == "household-table-v0":
        from siftom.world.domains.household import goal_space
    elif space == "kitchen-v0":
        from siftom.world.domains.kitchen import goal_space
    else:
        raise ObservationError(f"goal_space must be household-table-v0 or kitchen-v0, got {space!r}; or give 'goals'")
    return [Goal(g.name, target, g.counts) for g in goal_space(target)]


def feasible_goals(spec: GoalSpec, world: World, target: int) -> tuple[Goal, ...]:
    """The goals of the library ``spec`` names that the world's objects can satisfy (none: an error)."""
    have = Counter(it.cls for it in world.items)
    goals = goal_library(spec, target)
    feasible = [g for g in goals if all(have[c] >= n for c, n in g.counts)]
    if not feasible:
        raise ObservationError("no goal in the goal space can be reached with the objects in this scene"
                               + _why_unreachable(goals, world))
    return tuple(feasible)


def _why_unreachable(goals: list[Goal], world: World, show: int = 3) -> str:
    """What the first goals lack, with the scene's closest class names for a misspelt one."""
    have = Counter(it.cls for it in world.items)
    parts = []
    for g in goals[:show]:
        lacks = []
        for c, n in g.counts:
            if have[c] >= n:
                continue
            close = difflib.get_close_matches(c, list(have), n=2, cutoff=0.7) if have[c] == 0 else []
            hint = f" (did you mean {' or '.join(repr(x) for x in close)}?)" if close else ""
            lacks.append(f"{n} {c} (the scene has {have[c]}){hint}")
        parts.append(f"{g.name!r} needs {', '.join(lacks)}")
    more = f"; and {len(goals) - show} more goals" if len(goals) > show else ""
    return ": " + "; ".join(parts) + more


def goal_class_notes(spec: GoalSpec, world: World, target: int) -> tuple[str, ...]:
    """One warning per goal of a world's own ``goals`` that its objects cannot satisfy, naming the
    counted class the world lacks and its closest object classes (difflib), e.g. a goal counting
    ``"tomatoes"`` in a world of ``tomato`` objects. A named goal space is not checked: most of
    its goals are out of reach in any one world."""
    if spec.goals is None:
        return ()
    have = Counter(it.cls for it in world.items)
    out = []
    for g in goal_library(spec, target):
        for c, n in g.counts:
            if have[c] >= n:
                continue
            if have[c] == 0:
                close = difflib.get_close_matches(c, sorted(have), n=3, cutoff=0.6)
                hint = (f"did you mean {' or '.join(repr(x) for x in close)}? " if close
                        else f"the object classes are {', '.join(sorted(have)[:8])}; ")
                out.append(f"goal {g.name!r} counts {c!r}, a class no object has, so the robot never considers "
                           f"it: {hint}(rename the class in the goal, or add an object of class {c!r})")
            else:
                out.append(f"goal {g.name!r} needs {n} {c!r} and the world has {have[c]}, so the robot never "
                           f"considers it (lower the count, or add objects of class {c!r})")
    return tuple(out)
