"""The robot's loop in docs/service.md runs as written against a live server."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import httpx

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread

ROOT = Path(__file__).parents[2]


def test_the_documented_robot_loop_runs(tmp_path, monkeypatch):
    doc = (ROOT / "docs" / "service.md").read_text()
    code = re.search(r"\*\*A robot's loop\*\*.*?```python\n(.*?)```", doc, re.S).group(1)
    assert len(code.strip().splitlines()) <= 25
    monkeypatch.chdir(ROOT)

    class LossyClient(httpx.Client):
        """Every keyed request is sent twice, as a robot resends one whose reply it lost."""

        def post(self, *args, **kwargs):
            first = super().post(*args, **kwargs)
            if "Idempotency-Key" not in (kwargs.get("headers") or {}):
                return first
            again = super().post(*args, **kwargs)
            assert again.json() == first.json() and again.headers.get("idempotent-replayed") == "true"
            return again

    with serve_in_thread(create_app(tmp_path)) as url:
        out = io.StringIO()
        scope: dict = {}
        monkeypatch.setattr(httpx, "Client", LossyClient)
        with contextlib.redirect_stdout(out):
            exec(compile(code.replace("http://127.0.0.1:8000", url), "docs/service.md", "exec"), scope)
        monkeypatch.undo()
        view = httpx.get(f"{url}/v1/sessions/{scope['sid']}").json()
        once: dict = {}  # the same loop, each request sent once
        with contextlib.redirect_stdout(io.StringIO()):
            exec(compile(code.replace("http://127.0.0.1:8000", url), "docs/service.md", "exec"), once)
        expected = httpx.get(f"{url}/v1/sessions/{once['sid']}").json()
    text = out.getvalue()
    assert "robot does: fetch(tomato)" in text, text
    assert "-> salad" in text.splitlines()[-2]
    assert view["actions"] == expected["actions"]  # each action once, though every request went twice
    assert view["last_instruction"]["command"] == expected["last_instruction"]["command"]
