"""The robot's loop in docs/service.md runs as written against a live server."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

from siftom.service.app import create_app
from siftom.service.loadtest import serve_in_thread

ROOT = Path(__file__).parents[2]


def test_the_documented_robot_loop_runs(tmp_path, monkeypatch):
    doc = (ROOT / "docs" / "service.md").read_text()
    code = re.search(r"\*\*A robot's loop\*\*.*?```python\n(.*?)```", doc, re.S).group(1)
    assert len(code.strip().splitlines()) <= 25
    monkeypatch.chdir(ROOT)
    with serve_in_thread(create_app(tmp_path)) as url:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(code.replace("http://127.0.0.1:8000", url), "docs/service.md", "exec"), {})
    text = out.getvalue()
    assert "robot does: fetch(tomato)" in text, text
    assert "-> salad" in text.splitlines()[-2]
