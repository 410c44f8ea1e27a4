"""The documentation site builds with --strict; the version is one number everywhere."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import siftom
from siftom.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_mkdocs_builds_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs", reason="needs the docs extra: pip install 'siftom[docs]'")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), NO_MKDOCS_2_WARNING="1")
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    site = tmp_path / "site"
    http = (site / "reference" / "http" / "index.html").read_text(encoding="utf-8")
    assert "/v1/sessions" in http and "/v1/infer" in http  # the endpoint table from the OpenAPI schema
    assert '"openapi"' in (site / "reference" / "openapi.json").read_text(encoding="utf-8")
    assert "siftom infer" in (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "make_instruction" in (site / "reference" / "python" / "index.html").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs" / "tutorials").glob("*.md")):
        assert (site / "tutorials" / page.stem / "index.html").is_file(), page.name


def test_version_is_one_number(capsys: pytest.CaptureFixture[str]) -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["version"] == siftom.__version__
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"siftom {siftom.__version__}"
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert re.search(rf"^## \[{re.escape(siftom.__version__)}\]", changelog, re.MULTILINE)
