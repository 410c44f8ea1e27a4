"""A goal of a world's own list that counts a class no object has is named in a warning, with the
world's close class names, the way an object class no goal mentions is (the salad's "tomatoes")."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from siftom.cli import main
from siftom.world.io import load_scene, scene_from_json

ROOT = Path(__file__).resolve().parents[2]
SALAD = ROOT / "docs" / "examples" / "salad"


def _salad(**goal_counts: int) -> dict[str, object]:
    obj: dict[str, Any] = json.loads((SALAD / "world.json").read_text(encoding="utf-8"))
    obj["goals"][0]["counts"] = goal_counts
    return obj


def test_the_salad_as_shipped_has_no_notes() -> None:
    assert load_scene(SALAD / "world.json").notes == ()


def test_a_misspelt_goal_class_is_named_with_the_close_class() -> None:
    scene = scene_from_json(_salad(lettuce=1, cucumber=1, tomatoes=1, bowl=1))
    assert "salad" not in {g.name for g in scene.goals}  # the goal cannot be reached ...
    [note] = scene.notes  # ... and the loader says so, once, with the fix
    assert "'salad'" in note and "'tomatoes'" in note and "did you mean 'tomato'" in note


def test_a_count_the_world_cannot_meet_is_named() -> None:
    [note] = scene_from_json(_salad(lettuce=1, tomato=2)).notes
    assert "'salad' needs 2 'tomato'" in note and "has 1" in note


def test_infer_prints_the_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = tmp_path / "world.json"
    world.write_text(json.dumps(_salad(lettuce=1, cucumber=1, tomatoes=1, bowl=1)))
    code = main(["infer", "--scene", str(world), "--actions", str(SALAD / "actions.txt"),
                 "--transcript", "could you get me the potato", "--json"])
    assert code in (0, None)
    out = json.loads(capsys.readouterr().out)
    assert any("'tomatoes'" in w and "'tomato'" in w for w in out["warnings"]), out["warnings"]
