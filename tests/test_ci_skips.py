"""Under CI=true a skip for something missing fails; a skip for a brought service does not."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).parent

SAMPLE = '''
import pytest

@pytest.mark.skipif(True, reason="flite is not installed")
def test_tool(): pass

def test_package(): pytest.importorskip("no_such_module_for_siftom")

def test_data_dependent(): pytest.skip("no object on the target")

@pytest.mark.vlm
@pytest.mark.skipif(True, reason="needs a real vision model")
def test_brought_service(): pass
'''


def _run(tmp_path: Path, ci: str | None) -> str:
    shutil.copy(TESTS / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_sample.py").write_text(SAMPLE, encoding="utf-8")
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    vlm: x\n", encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    if ci is not None:
        env["CI"] = ci
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                          str(tmp_path)], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    return res.stdout.strip().splitlines()[-1]


def test_missing_things_fail_under_ci(tmp_path: Path) -> None:
    last = _run(tmp_path, "true")
    assert "1 failed" in last and "1 error" in last and "2 skipped" in last, last


def test_missing_things_skip_elsewhere(tmp_path: Path) -> None:
    last = _run(tmp_path, None)
    assert "4 skipped" in last and "failed" not in last, last
