"""The studies behind measured constants (``studies/``) still run against the product's public parts."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1] / "studies"


@pytest.mark.parametrize("name", sorted(p.name for p in STUDIES.glob("*.py")))
def test_a_study_imports(name: str) -> None:
    ns = runpy.run_path(str(STUDIES / name), run_name="study")
    assert ns.get("__doc__"), f"studies/{name} says what it measures and how to run it"


def test_the_nearness_study_measures_chance_levels() -> None:
    ns = runpy.run_path(str(STUDIES / "nearness.py"), run_name="study")
    out = ns["measure"](n=300, seed=1)
    assert out["words"] == 300 and out["scenes"] > 1
    assert out["chance_r"], "a chance level per phoneme length"
    assert all(0 < r < 1 for r in out["chance_r"].values())
    assert ns["measure"](n=300, seed=1) == out  # the same seed, the same numbers
