"""Check a model's action log and goal proposals against the world; PerceptionError says what is wrong.

Actions are parsed with :meth:`World.parse_action` and checked with the transition's own
legality test (:func:`siftom.world.model.check`) in order, so an accepted log is exactly one
``siftom infer --scene ... --actions ...`` accepts.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from siftom.errors import ObservationError, PerceptionError, UnknownNameError
from siftom.world.model import HUMAN, Action, Goal, State, World, apply, check


def check_actions(world: World, state: State, texts: Sequence[str]) -> tuple[list[Action], State]:
    """Parse and apply the person's actions in order; the state after them."""
    acts = []
    s = state
    for k, text in enumerate(texts):
        try:
            a = world.parse_action(text, s)
        except (ObservationError, UnknownNameError) as exc:
            raise PerceptionError(f"action {k + 1} {text!r}: {exc}") from None
        if a.agent != HUMAN:
            raise PerceptionError(f"action {k + 1} {text!r}: report only the person's actions (agent 'human'); "
                                  "the robot's own actions are not observations")
        why = check(world, s, a)
        if why is not None:
            raise PerceptionError(f"action {k + 1} {text!r} is impossible after the actions before it: {why}")
        acts.append(a)
        s = apply(s, a)
    return acts, s


@dataclass(frozen=True)
class NamedGoal:
    """A goal of a perceived world, before its target is known: a name and how many objects of
    each class (in the order given); its JSON is world JSON's ``{"name", "counts": {class: n}}``."""

    name: str
    counts: tuple[tuple[str, int], ...]

    @property
    def key(self) -> tuple[tuple[str, int], ...]:
        """The counts in a fixed order: two goals with the same key are the same goal."""
        return tuple(sorted(self.counts))

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "counts": dict(self.counts)}


@dataclass(frozen=True)
class GoalProposal:
    """The model's answer to the goals question (schema ``goals``), as given: the target place
    and each goal's name and counts (a class listed twice is kept, for :func:`check_goals` to refuse)."""

    target: str
    goals: tuple[NamedGoal, ...]

    @classmethod
    def from_json(cls, answer: dict[str, Any]) -> GoalProposal:
        """From a schema-valid answer (``{"target", "goals": [{"name", "counts": [{"class", "count"}]}]}``)."""
        return cls(answer["target"], tuple(NamedGoal(g["name"], tuple((c["class"], c["count"]) for c in g["counts"]))
                                           for g in answer["goals"]))


def check_goals(world: World, proposal: GoalProposal) -> tuple[str, list[NamedGoal]]:
    """The target place and the goals, checked against the world's places and objects."""
    target = proposal.target
    names = {p.name for p in world.places}
    if target not in names:
        from siftom.errors import unknown_name

        raise PerceptionError(f"target: {unknown_name('place', target, names)}")
    have = Counter(it.cls for it in world.items)
    problems: list[str] = []
    goals: list[NamedGoal] = []
    seen: set[str] = set()
    for k, g in enumerate(proposal.goals):
        counts: dict[str, int] = {}
        for cls, n in g.counts:
            if cls in counts:
                problems.append(f"goals[{k}] ({g.name}) lists {cls!r} twice")
            elif cls not in have:
                from siftom.errors import unknown_name

                problems.append(f"goals[{k}] ({g.name}): {unknown_name('object class', cls, have)}")
            elif n > have[cls]:
                problems.append(f"goals[{k}] ({g.name}) needs {n} {cls} but the scene has {have[cls]}")
            counts[cls] = n
        if g.name in seen:
            problems.append(f"goals[{k}]: the name {g.name!r} is used twice; give each goal its own name")
        seen.add(g.name)
        goals.append(NamedGoal(g.name, tuple(counts.items())))
    if problems:
        raise PerceptionError("invalid goals: " + "; ".join(problems))
    return target, goals


GOAL_LIBRARIES = ("household-table-v0", "kitchen-v0")


def _library(goal_space: str) -> tuple[Goal, ...]:
    if goal_space not in GOAL_LIBRARIES:
        from siftom.errors import unknown_name

        raise unknown_name("goal library", goal_space, GOAL_LIBRARIES)
    if goal_space == "kitchen-v0":
        from siftom.world.domains.kitchen import goal_space as space
    else:
        from siftom.world.domains.household import goal_space as space
    return space(0)


def library_classes(goal_space: str | None) -> list[str]:
    """Every object class a goal library mentions (suggested to the model as names to use)."""
    if goal_space is None:
        return []
    return sorted({c for g in _library(goal_space) for c, _ in g.counts})


def library_goals(world: World, goal_space: str | None) -> list[NamedGoal]:
    """A domain's goal library (household-table-v0, kitchen-v0), only goals this world can reach."""
    if goal_space is None:
        return []
    have = Counter(it.cls for it in world.items)
    return [NamedGoal(g.name, g.counts) for g in _library(goal_space) if all(have[c] >= n for c, n in g.counts)]


def merge_goals(proposed: Sequence[NamedGoal], library: Sequence[NamedGoal]) -> list[NamedGoal]:
    """Library goals first (their names win), then proposed goals the library lacks.

    Two goals are the same when their counts are; a proposed goal whose name a library goal
    already uses gets the suffix ``_proposed``.
    """
    out = list(library)
    have = {g.key for g in out}
    names = {g.name for g in out}
    for g in proposed:
        if g.key in have:
            continue
        name = g.name if g.name not in names else f"{g.name}_proposed"
        out.append(NamedGoal(name, g.counts))
        have.add(g.key)
        names.add(name)
    return out
