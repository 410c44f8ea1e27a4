"""A plug-in evaluator kind for the tests: it always asks for the scenario's first object class."""

from __future__ import annotations

from siftom.bench.choosers import Choice, Trial


def choose_first(t: Trial) -> Choice:
    return Choice(f"fetch({sorted(t.scenario.world.classes)[0]})", 0.5)
