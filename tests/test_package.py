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
    assert "siftom demo" in line
    assert "python -m build --wheel" in head, "the head should say how to install as a wheel too"


def test_every_file_the_package_reads_is_in_its_package_data():
    """A file beside the code (a grammar, a page, a model list) that the wheel leaves out breaks every
    installed copy while the checkout works: each one must match a package-data pattern."""
    import fnmatch
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    patterns = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"][
        "package-data"]["siftom"]
    src = root / "src" / "siftom"
    files = [p.relative_to(src).as_posix() for p in src.rglob("*")
             if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts]
    left_out = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert not left_out, f"add these to [tool.setuptools.package-data] in pyproject.toml: {left_out}"
    assert "language/grammar.lark" in files
