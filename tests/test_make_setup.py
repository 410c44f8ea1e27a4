"""What `make demo` and `make test` install (read with `make -n`, nothing is run), and the README's
pip line: the demo gets only what `siftom demo` runs on, with the download shown; the tests the rest."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs make")


def _plan(target: str, venv: Path) -> list[str]:
    # a make of its own, also when the suite runs under `make test` (no inherited flags, no
    # "Entering directory" lines)
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL", "MFLAGS")}
    res = subprocess.run(["make", "--no-print-directory", "-n", target, f"VENV={venv}"], cwd=ROOT,
                         capture_output=True, text=True, timeout=60, env=env)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


def _installs(lines: list[str]) -> list[tuple[set[str], str]]:
    """(extras, the whole line) of each `pip install -e ".[...]"` in a plan."""
    out = []
    for ln in lines:
        m = re.search(r'pip install .*-e "\.\[([^\]]*)\]"', ln)
        if m:
            out.append((set(m.group(1).split(",")), ln))
    return out


def _demo_extras() -> set[str]:
    m = re.search(r"^DEMO_EXTRAS \?= (.+)$", (ROOT / "Makefile").read_text(encoding="utf-8"), re.MULTILINE)
    assert m, "the Makefile names the demo's extras in DEMO_EXTRAS"
    return set(m.group(1).strip().split(","))


def test_make_demo_installs_only_what_the_demo_needs_and_shows_it(tmp_path: Path) -> None:
    plan = _plan("demo", tmp_path / "venv")
    installs = _installs(plan)
    assert len(installs) == 1, plan
    extras, line = installs[0]
    assert "whisper" in extras  # the acoustic likelihood of `siftom demo`
    assert not extras & {"dev", "docs", "ros", "tts-neural", "fast", "ray", "llm"}, extras
    assert " -q" not in line  # pip's progress is shown
    said = "\n".join(plan[:plan.index(line)])
    assert "echo" in said and "MB" in said  # what is being installed, and how large
    assert plan[-1].endswith("siftom demo")


def test_make_test_installs_the_rest_after_the_demo(tmp_path: Path) -> None:
    plan = _plan("test", tmp_path / "venv")
    installs = _installs(plan)
    assert [e for e, _ in installs][0] == _demo_extras()
    assert {"dev", "docs", "whisper"} <= installs[-1][0]
    assert any("pytest" in ln for ln in plan)


def test_the_readme_pip_line_installs_what_the_demo_needs() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if "pip install" in ln and "siftom demo" in ln]
    assert lines, "README shows the pip line that runs the demo"
    for ln in lines:
        m = re.search(r'pip install "\.\[([^\]]*)\]"', ln)
        assert m and set(m.group(1).split(",")) == _demo_extras(), ln
    for wheel in re.findall(r'pip install "\$\(ls dist/siftom-\*\.whl\)\[([^\]]*)\]"', text):
        assert set(wheel.split(",")) == _demo_extras()
