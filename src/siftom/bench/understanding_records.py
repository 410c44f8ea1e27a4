"""The understanding benchmark's records: an item (:class:`Item`) and what a listener should
understand from it (:class:`Expect`), for the generated sets (:mod:`siftom.bench.understanding_items`)
and the hand-written ones (:mod:`siftom.bench.understanding_blind`) alike."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Expect:
    """What a listener should understand from an item.

    Attributes:
        request: whether somebody asked the robot for something.
        targets: (object class, count said or None) for each object asked for.
        absent: the name of the object asked for that is not in the world ('' for none).
        optional: classes a listener may also take as asked for (the sugar of "the cereal with a
            bit of sugar"); each at most once beside the targets.
        refused: classes the person ruled out ("anything but the sugar", "not the cheese"): never
            carried out, never offered in a question.
        over_supply: the count said is more than the world holds ("three pens" where two are):
            any number of the target's class, up to the count said, is understood.
    """

    request: bool
    targets: tuple[tuple[str, int | None], ...] = ()
    absent: str = ""
    optional: tuple[str, ...] = ()
    refused: tuple[str, ...] = ()
    over_supply: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"request": self.request, "targets": [[c, n] for c, n in self.targets],
                "absent": self.absent or None, "optional": list(self.optional), "refused": list(self.refused),
                "over_supply": self.over_supply}

    @property
    def wants_object(self) -> bool:
        """Whether the person asked for objects that are here (a silent robot ignored them)."""
        return self.request and bool(self.targets) and not self.absent


@dataclass(frozen=True)
class Item:
    """One utterance of the benchmark in one world.

    Attributes:
        id: ``SET/DOMAIN/wW-K/KIND/J`` (generated sets) or ``blind/KIND/NN``.
        kind: one of :data:`KINDS` or :data:`BLIND_KINDS`.
        domain: the domain id (a world file's items: ``world:NAME``).
        scenario_seed: the generator seed of the world (``world_scenario_seed``); None for a
            registered scenario.
        text: what the person says.
        expect: what should be understood.
        scenario: the scenario id (``kitchen-v0/w201-0``, ``kitchen-v0/3``); '' for a world file.
        template: the template the text was made from ('' for a hand-written item).
        world: the world file of the items' data (``office``: ``data/understanding/worlds/office.json``
            with the person's actions in ``office.actions.txt``); '' for a scenario.
        pending: the two commands of the question the robot asked before these words ("Which one:
            the cheese or the plate?"); the text is the person's reply. Empty: no question open.
    """

    id: str
    kind: str
    domain: str
    scenario_seed: int | None
    text: str
    expect: Expect
    scenario: str = ""
    template: str = ""
    world: str = ""
    pending: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "domain": self.domain, "scenario": self.scenario,
                "scenario_seed": self.scenario_seed, "world": self.world or None, "text": self.text,
                "template": self.template, "pending": list(self.pending) or None, "expected": self.expect.to_json()}
