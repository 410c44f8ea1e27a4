"""Scenarios and the registry of domains (versioned ids, lazy ``module:attr`` entry points)."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from siftom.errors import CommandParseError, unknown_name
from siftom.world.commands import VALID_FORMS, RobotCommand
from siftom.world.model import AGENT_NAMES, Action, Goal, State, World, apply


@dataclass(frozen=True, eq=False)
class Scenario:
    """A world, a start state, the goal space and what the human did before speaking.

    Attributes:
        id: registry id (``household-table-v0/3``, ``kitchen-cereal-v0``).
        domain: the domain id.
        world: static layout.
        start: state before the observed actions.
        goals: the goal space the robot reasons over (the true goal is one of them).
        true_goal: index into ``goals`` of the human's goal.
        command: the robot's part the human asks for (gold answer).
        actions: the human's observed actions, in order, before the instruction.
        verb: ``deliver`` (household) or ``fetch`` (kitchen).
        description: one line for people.
    """

    id: str
    domain: str
    world: World
    start: State
    goals: tuple[Goal, ...]
    true_goal: int
    command: RobotCommand
    actions: tuple[Action, ...]
    verb: str
    description: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def target(self) -> int:
        return self.goals[0].target

    @property
    def goal(self) -> Goal:
        return self.goals[self.true_goal]

    def states(self) -> list[State]:
        """States visited by the observed actions (len(actions) + 1)."""
        out = [self.start]
        for a in self.actions:
            out.append(apply(out[-1], a))
        return out

    @property
    def now(self) -> State:
        """The state when the human speaks."""
        return self.states()[-1]

    def parse_command(self, text: str) -> RobotCommand:
        """Parse a command and check it names an object class of this world."""
        cmd = RobotCommand.parse(text)
        if cmd.obj_class not in self.world.classes:
            raise CommandParseError(
                f"{text!r}: no object of class {cmd.obj_class!r} in {self.id}; classes here: "
                f"{', '.join(self.world.classes)}. Valid forms: {VALID_FORMS}"
            )
        n = sum(1 for it in self.world.items if it.cls == cmd.obj_class)
        if cmd.count > n:
            raise CommandParseError(f"{text!r}: only {n} {cmd.obj_class} exist in {self.id}")
        return cmd

    def summary(self) -> dict[str, Any]:
        """A JSON-able description."""
        w = self.world
        s = self.start
        return {
            "id": self.id,
            "domain": self.domain,
            "description": self.description,
            "rooms": sorted({p.room for p in w.places}),
            "places": [
                {"name": p.name, "kind": p.kind, "room": p.room, "pos": list(p.pos), "closable": p.closable,
                 "open": s.is_open(i) if p.closable else None}
                for i, p in enumerate(w.places)
            ],
            "objects": [
                {"name": it.name, "class": it.cls, "at": w.places[s.item_at[i]].name if s.item_at[i] >= 0 else "held"}
                for i, it in enumerate(w.items)
            ],
            "agents": {AGENT_NAMES[k]: w.places[p].name for k, p in enumerate(s.agent_at)},
            "target": w.places[self.target].name,
            "goal": {"name": self.goal.name, "counts": dict(self.goal.counts)},
            "num_goals": len(self.goals),
            "command": str(self.command),
            "actions": [w.format_action(a) for a in self.actions],
        }


@dataclass(frozen=True)
class DomainSpec:
    """A registered domain: id, docstring-level description and how to make scenarios."""

    id: str
    description: str
    entry_point: str  # "module:attr" of a class with generate(seed) and fixed() methods

    def load(self) -> Any:
        module, attr = self.entry_point.split(":")
        return getattr(importlib.import_module(module), attr)()


_DOMAINS: dict[str, DomainSpec] = {}
_SCENARIOS: dict[str, tuple[str, Callable[[], Scenario]]] = {}


def register_domain(spec: DomainSpec) -> None:
    _DOMAINS[spec.id] = spec


def register_scenario(sid: str, domain: str, factory: Callable[[], Scenario]) -> None:
    _SCENARIOS[sid] = (domain, factory)


def _ensure_builtin() -> None:
    # importing registers them; always import both, whichever module was imported first
    from siftom.world.domains import household, kitchen  # noqa: F401


def domains() -> Sequence[DomainSpec]:
    _ensure_builtin()
    return [(_DOMAINS[k]) for k in sorted(_DOMAINS)]


def get_domain(domain_id: str) -> Any:
    """The domain object (with ``generate(seed)`` and ``fixed()``) for an id."""
    _ensure_builtin()
    if domain_id not in _DOMAINS:
        raise unknown_name("domain", domain_id, _DOMAINS)
    return _DOMAINS[domain_id].load()


def scenario_ids() -> list[str]:
    _ensure_builtin()
    return sorted(_SCENARIOS, key=_natural)


def _natural(s: str) -> tuple:
    import re

    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", s))


_CACHE: dict[str, Scenario] = {}


def get_scenario(sid: str) -> Scenario:
    """A registered scenario by id, e.g. ``kitchen-cereal-v0`` or ``household-table-v0/3``."""
    _ensure_builtin()
    if sid not in _SCENARIOS:
        raise unknown_name("scenario", sid, _SCENARIOS)
    if sid not in _CACHE:
        _CACHE[sid] = _SCENARIOS[sid][1]()
    return _CACHE[sid]


def scenario_domain(sid: str) -> str:
    _ensure_builtin()
    if sid not in _SCENARIOS:
        raise unknown_name("scenario", sid, _SCENARIOS)
    return _SCENARIOS[sid][0]
