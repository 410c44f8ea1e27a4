"""Smoke tests: each recipe under recipes/ runs on the public API and says what it measured."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from siftom.bench.sweep import load_config

ROOT = Path(__file__).resolve().parents[1]
RECIPES = ROOT / "recipes"


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("script", sorted(RECIPES.glob("*.py")), ids=lambda p: p.name)
def test_recipes_use_public_names_only(script: Path) -> None:
    tree = ast.parse(script.read_text(encoding="utf-8"))
    private = [f"{n.module}.{a.name}" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
               and n.module.startswith("siftom") for a in n.names if a.name.startswith("_")]
    private += [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module and n.module.startswith("siftom")
                and any(part.startswith("_") for part in n.module.split("."))]
    assert not private, f"{script.name} imports private names: {private}"
    assert ast.get_docstring(tree), f"{script.name} has no docstring saying how to run it"


def test_costtogo_recipe_runs(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "costtogo_scenarios.py"), "--goals", "none", "--scenarios", "kitchen-cereal-v0",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "fast - A* = +0" in res.stdout and "differing cases: 0" in res.stdout


def test_sweep_example_loads() -> None:
    cfg = load_config(RECIPES / "sweep_example.toml")
    assert cfg is not None


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_ray_scaling_recipe_runs_locally(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "ray_scaling.py"), "--backend", "local", "--workers", "1", "--out", str(tmp_path),
               "--models", "siftom", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "identical results.jsonl: True" in res.stdout


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_instruction_gate_recipe_runs(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "instruction_gate.py"), "--out", str(tmp_path / "gate"), "--scenarios", "1",
               "--speakers", "1", "--snr", "none", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    import json

    summary = json.loads((tmp_path / "gate" / "summary.json").read_text())
    assert set(summary["rates"]) == {"request", "off-topic"}
    assert summary["rates"]["off-topic"]["all"]["n"] == summary["rates"]["request"]["all"]["n"] == 1
    assert "off-topic" in res.stdout and "refused" in res.stdout
