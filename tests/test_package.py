"""The package root: the one-call API on first use, and a light import."""

import subprocess
import sys

import pytest


def test_the_root_exposes_the_one_call_api():
    import siftom
    import siftom.api

    assert siftom.listen is siftom.api.listen
    assert siftom.infer_scenario is siftom.api.infer_scenario
    with pytest.raises(AttributeError, match="no attribute 'lisen'"):
        siftom.lisen  # noqa: B018


def test_import_siftom_loads_no_model_code():
    code = "import sys, siftom; print('siftom.api' in sys.modules, 'numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_readme_shows_the_install_line_beside_the_two_make_commands():
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    head = readme.split("## A five-minute tour", 1)[0]  # what a newcomer reads first
    assert "make demo" in head and "make test" in head
    line = next((ln for ln in head.splitlines() if ln.startswith("pip install ")), None)
    assert line is not None, "no pip install line before the tour"
    assert "siftom demo" in line and "python -m build --wheel" in line
