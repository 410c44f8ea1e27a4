"""Other packages add to siftom's registries through entry points (group ``siftom.plugins``).

The plug-in in tests/fixtures/siftom_demo_plugin is installed into a temporary folder as an
installer would (the package and its ``.dist-info`` with ``entry_points.txt``), and siftom run
with that folder on its path sees its likelihood and scenario.
"""

import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

FIXTURE = Path(__file__).parent / "fixtures" / "siftom_demo_plugin"
SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A folder holding the installed plug-in: its package and its .dist-info metadata."""
    out = tmp_path_factory.mktemp("site")
    shutil.copytree(FIXTURE / "siftom_demo_plugin", out / "siftom_demo_plugin")
    meta = tomllib.loads((FIXTURE / "pyproject.toml").read_text())["project"]
    info = out / f"siftom_demo_plugin-{meta['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {meta['name']}\nVersion: {meta['version']}\n")
    eps = meta["entry-points"]["siftom.plugins"]
    (info / "entry_points.txt").write_text("[siftom.plugins]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items()))
    return out


def _siftom(site, *args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), str(site)])}
    return subprocess.run([sys.executable, "-m", "siftom.cli", *args], capture_output=True, text=True,
                          env=env, timeout=300)


def test_the_plugin_is_listed(site):
    r = _siftom(site, "plugins", "--json")
    assert r.returncode == 0, r.stderr
    regs = json.loads(r.stdout)
    assert "keyword" in [e["name"] for e in regs["instruction likelihood"]]
    assert "demo-v0" in [e["name"] for e in regs["domain"]]


def test_the_plugin_is_usable_from_infer(site):
    r = _siftom(site, "infer", "--scenario", "demo-salad-v0", "--likelihood", "keyword",
                "--transcript", "could you get me the tomato", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["command"] == "fetch(tomato)" and out["likelihood"] == "keyword"
    assert out["evidence"]["keyword_hits"] == 1 and out["evidence"]["likelihood"] == "keyword"


def test_without_the_plugin_the_names_are_unknown():
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    r = subprocess.run([sys.executable, "-m", "siftom.cli", "infer", "--scenario", "demo-salad-v0",
                        "--transcript", "tomato"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and "demo-salad-v0" in r.stderr


def test_a_broken_plugin_is_reported_not_fatal(tmp_path, site):
    broken = tmp_path / "broken"
    shutil.copytree(site, broken)
    (broken / "siftom_demo_plugin" / "__init__.py").write_text("def register():\n    raise RuntimeError('boom')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), str(broken)])}
    code = "from siftom.registry import plugin_errors, load_all; load_all(); print(dict(plugin_errors()))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "boom" in r.stdout and "demo" in r.stdout


def test_a_plugin_likelihood_is_evaluated_by_siftom_eval(site, tmp_path):
    """Every registered likelihood is an evaluator model (``siftom-<name>``), with no edit to siftom."""
    data, out = tmp_path / "data", tmp_path / "out"
    r = _siftom(site, "dataset", "build", "--domain", "kitchen-v0", "--scenarios", "1", "--speakers", "1",
                "--voices", "flite-slt", "--snr", "none", "--out", str(data), "--workers", "1")
    assert r.returncode == 0, r.stderr
    r = _siftom(site, "eval", "--dataset", str(data), "--out", str(out), "--models", "siftom-keyword,siftom-phonetic",
                "--workers", "1", "--json")
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert rows and all(set(row["models"]) == {"siftom-keyword", "siftom-phonetic"} for row in rows)
    for row in rows:
        m = row["models"]["siftom-keyword"]
        assert m["command"].startswith("fetch(") and isinstance(m["correct"], bool)
    run = json.loads((out / "run.json").read_text())
    assert {"name": "siftom-keyword", "kind": "posterior", "likelihood": "keyword", "mode": "full",
            "heard": "nbest", "rule": "map"} in run["options"]["plugin_models"]
    # without the plug-in the model is unknown, with the close names listed
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    r = subprocess.run([sys.executable, "-m", "siftom.cli", "eval", "--dataset", str(data), "--out",
                        str(tmp_path / "o2"), "--models", "siftom-keyword"], capture_output=True, text=True, env=env,
                       timeout=300)
    assert r.returncode != 0 and "siftom-keyword" in r.stderr
