"""`siftom serve` as a real process: a robot's session survives the server being killed.

Creates a session from the VirtualHome apartment graph, streams script lines one by one, sends
an instruction, kills the server (SIGKILL: no clean shutdown), starts it again on the same
data directory and finds the session unchanged; then the session carries on.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

httpx = pytest.importorskip("httpx")

from siftom.service.local_server import free_port  # noqa: E402
from support.server import kill_server as _kill  # noqa: E402
from support.server import start_server as _start  # noqa: E402

ROOT = Path(__file__).parents[2]
VIRTUALHOME = ROOT / "data" / "virtualhome" / "apartment_graph.json"
LINES = ["<char0> [Walk] <kitchen> (56)", "[Walk] <dishwasher> (159)", "[Open] <dishwasher> (159)",
         "[Grab] <cutleryfork> (1006)", "[Walk] <kitchentable> (130)",
         "[PutBack] <cutleryfork> (1006) <kitchentable> (130)", "[Walk] <dishwasher> (159)",
         "[Grab] <cutleryfork> (1007)", "[PutBack] <cutleryfork> (1007) <kitchentable> (130)"]

pytestmark = [pytest.mark.slow,  # two server start-ups: ~13 s on the shared 2-core machine
              pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"needs {VIRTUALHOME}")]


def test_killed_server_restarts_and_continues_the_session(tmp_path):
    port, data = free_port(), tmp_path / "data"
    proc = _start(port, data)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as c:
            r = c.post("/v1/sessions", json={"world": json.loads(VIRTUALHOME.read_text())})
            assert r.status_code == 201, r.text
            sid = r.json()["id"]
            for line in LINES:
                r = c.post(f"/v1/sessions/{sid}/actions", json={"actions": [line]})
                assert r.status_code == 200, r.text
            r = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "could you bring me two wine glasses"})
            assert r.status_code == 200, r.text
            assert r.json()["command"] == "deliver(wineglass,2)"
            before = c.get(f"/v1/sessions/{sid}").json()
            assert before["n_actions"] == 9 and before["last_instruction"]["command"] == "deliver(wineglass,2)"
    finally:
        _kill(proc)
    proc = _start(port, data)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as c:
            assert c.get(f"/v1/sessions/{sid}").json() == before
            r = c.post(f"/v1/sessions/{sid}/actions", json={"actions": ["[Walk] <fridge> (165)"]})
            assert r.status_code == 200 and r.json()["n_actions"] == 10
    finally:
        _kill(proc)
