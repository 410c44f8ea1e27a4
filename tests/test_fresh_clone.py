"""The tests that print text pass in a fresh clone at a long path with an 80-column terminal:
nothing in them depends on the checkout's folder, its path's length or the terminal's width.

The clone is of the committed HEAD (work not committed yet is not in it).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow

# the test files that check what the command line prints
TEXT_TESTS = ("tests/test_siftom_cli.py", "tests/test_stream_cli.py", "tests/test_demo.py",
              "tests/world/test_scenegraph.py", "tests/world/test_vhscript.py", "tests/speech/test_cli.py",
              "tests/test_package.py", "tests/test_screenshots.py")


def test_text_printing_tests_pass_in_a_clone_at_a_long_path_at_80_columns(tmp_path: Path) -> None:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and a git checkout (the clone is made with git clone)")
    far = tmp_path / ("x" * 110) / "siftom"
    far.parent.mkdir(parents=True)
    res = subprocess.run(["git", "clone", "-q", str(ROOT), str(far)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert len(str(far)) > 100
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTEST_ADDOPTS")}
    env.update(COLUMNS="80", LINES="24", PYTHONPATH=str(far / "src"))
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *TEXT_TESTS],
                         cwd=far, env=env, capture_output=True, text=True, timeout=1200)
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-2000:]
    assert " passed" in res.stdout.splitlines()[-1]
