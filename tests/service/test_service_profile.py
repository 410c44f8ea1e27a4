"""Smoke test: recipes/service_profile.py times a POST /v1/infer request by part and says so."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_profile_recipe_breaks_a_request_down_by_part(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), MPLBACKEND="Agg")
    res = subprocess.run([sys.executable, str(ROOT / "recipes" / "service_profile.py"), "--rounds", "1",
                          "--requests", "12", "--json"], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    ms = out["ms_per_request"]["this"]
    assert set(ms) == {"wall", "total", "middleware", "validation", "observer", "decision", "reply", "serialisation"}
    assert all(v > 0 for v in ms.values()), ms
    parts = sum(v for k, v in ms.items() if k not in ("total", "wall"))
    assert 0.8 * ms["total"] <= parts <= 1.05 * ms["total"], ms  # the parts account for the request
    assert out["machine"]["cpus"] >= 1 and out["machine"]["processor"]
