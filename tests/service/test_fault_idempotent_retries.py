"""The service killed (SIGKILL) in the middle of a robot's request stream, restarted on the same
data directory, and the robot retrying with the same Idempotency-Keys: the stored session is
exactly what the robot was told, nothing lost and nothing twice."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

httpx = pytest.importorskip("httpx")

from siftom.service.local_server import free_port  # noqa: E402
from support.server import kill_server as _kill  # noqa: E402
from support.server import server_env as _env  # noqa: E402
from support.server import start_server as _start  # noqa: E402

ROOT = Path(__file__).parents[2]
SALAD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
ACTIONS = [ln for ln in (ROOT / "docs" / "examples" / "salad" / "actions.txt").read_text().splitlines()
           if ln.strip() and not ln.startswith("#")]

pytestmark = pytest.mark.slow  # three server start-ups: ~20 s on the shared 2-core machine


def test_sigkill_mid_stream_then_retries_with_the_same_keys(tmp_path):
    port, data = free_port(), tmp_path / "data"
    url = f"http://127.0.0.1:{port}"
    proc = _start(port, data)
    try:
        # a second server on the same folder is refused while the first lives
        second = subprocess.run([sys.executable, "-m", "siftom.cli", "serve", "--port", str(free_port()),
                                 "--data-dir", str(data)], env=_env(), capture_output=True, text=True, timeout=60)
        assert second.returncode == 2 and "another --data-dir" in second.stderr, second.stderr
        told: dict[str, dict] = {}  # Idempotency-Key -> the answer the robot got
        with httpx.Client(base_url=url, timeout=30) as api:
            sid = api.post("/v1/sessions", json={"world": SALAD}).raise_for_status().json()["id"]

            def send(path: str, body: dict, key: str) -> dict:
                for _ in range(200):  # the robot retries until it gets an answer, always with the same key
                    try:
                        r = api.post(f"/v1/sessions/{sid}/{path}", json=body, headers={"Idempotency-Key": key})
                    except httpx.HTTPError:
                        time.sleep(0.1)
                        continue
                    assert r.status_code == 200, r.text
                    told[key] = r.json()
                    return told[key]
                raise AssertionError(f"no answer to {key}")

            kills = {3: 0.0, 6: 0.02}  # kill while these requests are in flight (after this many seconds)
            for k, line in enumerate(ACTIONS):
                if k in kills:
                    t = threading.Thread(target=send, args=("actions", {"actions": [line]}, f"act-{k}"))
                    t.start()
                    time.sleep(kills[k])
                    _kill(proc)
                    proc = _start(port, data)  # the retry inside the thread reaches the new server
                    t.join(timeout=120)
                    assert f"act-{k}" in told
                else:
                    send("actions", {"actions": [line]}, f"act-{k}")
                # a retry of an answered request changes nothing and repeats the answer
                if k % 2:
                    again = api.post(f"/v1/sessions/{sid}/actions", json={"actions": [line]},
                                     headers={"Idempotency-Key": f"act-{k}"})
                    assert again.json() == told[f"act-{k}"]
            said = send("instruction", {"transcript": "can you get me the potato"}, "say-0")
            _kill(proc)
            proc = _start(port, data)
            assert send("instruction", {"transcript": "can you get me the potato"}, "say-0") == said
            view = api.get(f"/v1/sessions/{sid}").json()
        added = [a for k in range(len(ACTIONS)) for a in told[f"act-{k}"]["added"]]
        assert view["actions"] == added  # nothing lost, nothing twice
        assert [told[f"act-{k}"]["n_actions"] for k in range(len(ACTIONS))] == list(range(1, len(ACTIONS) + 1))
        assert view["last_instruction"] == said and said["command"] == "fetch(tomato)"
    finally:
        if proc.poll() is None:
            _kill(proc)
