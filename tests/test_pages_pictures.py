"""The README's picture is one `make pages` drew (`siftom demo`), and it carries the version that
drew it: a release that changes what the robot does redraws it."""

from __future__ import annotations

from pathlib import Path

import pytest

import siftom

ROOT = Path(__file__).resolve().parents[1]


def test_the_demo_picture_carries_the_version_that_drew_it() -> None:
    pil = pytest.importorskip("PIL.Image", reason="needs pillow (matplotlib's dependency)")
    assert "](docs/img/demo.png)" in (ROOT / "README.md").read_text(encoding="utf-8")
    info = pil.open(ROOT / "docs" / "img" / "demo.png").info
    assert info.get("Software") == f"siftom {siftom.__version__}", \
        f"docs/img/demo.png was drawn by {info.get('Software', 'an unknown version')}; run: make pages"
    assert "siftom demo" in (ROOT / "Makefile").read_text(encoding="utf-8").split("\npages:", 1)[1].split("\n\n", 1)[0]


def test_pictures_the_code_draws_carry_its_version(tmp_path: Path) -> None:
    pil = pytest.importorskip("PIL.Image", reason="needs pillow (matplotlib's dependency)")
    from siftom.scenarios.base import get_scenario
    from siftom.world.render import render_scenario

    out = render_scenario(get_scenario("kitchen-cereal-v0"), tmp_path / "scene.png")
    assert pil.open(out).info.get("Software") == f"siftom {siftom.__version__}"
