"""Nobody who reaches a recording page can take over a participant by agreeing again: a
participant with a key gets it back only by sending it, and only the experimenter
(``siftom collect --participant ID --new-key``) can give them a new one."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from siftom.people.collect import Collection, CollectOptions
from siftom.service.collect_app import create_collect_app
from siftom.speech.audio import wav_bytes
from support.client import local_client


def _voice() -> bytes:
    t = np.arange(16000) / 16000
    return wav_bytes((0.3 * np.sin(2 * np.pi * 200.0 * t)).astype(np.float32))


def _record(c: Any, pid: str, key: str) -> Any:
    return c.post("/api/recordings", data={"participant": pid, "index": "0", "reference": "the milk please",
                                           "key": key}, files={"audio": ("r.wav", _voice())})


def _agree(c: Any, pid: str, key: str | None = None) -> Any:
    body: dict[str, Any] = {"participant": pid, "agree": True}
    if key is not None:
        body["key"] = key
    return c.post("/api/participants", json=body)


def _page(out: Path, participant: str | None = "p01") -> Any:
    return local_client(create_collect_app(out, CollectOptions(domain="kitchen-v0", scenarios=1,
                                                               participant=participant)))


def test_agreeing_again_on_the_participants_page_does_not_lock_them_out(tmp_path):
    page = _page(tmp_path / "ds")
    first = _agree(page, "p01")
    assert first.status_code == 200
    key = first.json()["key"]
    assert _record(page, "p01", key).status_code == 201
    # someone else reaches the page and agrees again as p01
    r = _agree(page, "p01")
    assert r.status_code == 403
    detail = r.json()["detail"]
    assert "p01" in detail and "siftom collect --participant p01 --new-key" in detail
    for wrong in ("", "x" * 32):
        assert _agree(page, "p01", wrong).status_code == 403
    # the real participant still records with their key, and gets the same key back with it
    assert _record(page, "p01", key).status_code == 201
    again = _agree(page, "p01", key)
    assert again.status_code == 200 and again.json()["key"] == key


def test_the_experimenter_resets_a_key_and_the_next_agreement_gets_a_new_one(tmp_path):
    out = tmp_path / "ds"
    page = _page(out)
    old = _agree(page, "p01").json()["key"]
    coll: Collection = page.app.state.collection
    assert coll.reset_key("p01") is True
    assert _record(page, "p01", old).status_code == 403  # the old key stops working
    new = _agree(page, "p01")
    assert new.status_code == 200 and new.json()["key"] != old
    assert _record(page, "p01", new.json()["key"]).status_code == 201
    assert _agree(page, "p01").status_code == 403  # and it is theirs again
    assert coll.reset_key("p99") is False  # nobody to reset
    lines = [json.loads(x) for x in (out / "participants.jsonl").read_text().splitlines()]
    assert any(r.get("key_reset") for r in lines) and old not in (out / "participants.jsonl").read_text()


def test_collect_new_key_resets_before_serving(tmp_path, monkeypatch):
    from click.testing import CliRunner

    import siftom.cli.people as people_cli
    from siftom.cli import root

    out = tmp_path / "ds"
    old = _agree(_page(out), "p01").json()["key"]
    served: dict[str, Any] = {}
    monkeypatch.setattr(people_cli, "_serve", lambda app, *a, **kw: served.update(app=app))
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    res = CliRunner().invoke(root, ["collect", "--domain", "kitchen-v0", "--out", str(out), "--scenarios", "1",
                                    "--participant", "p01", "--new-key"])
    assert res.exit_code == 0, res.output
    assert "old key no longer works" in res.output
    page = local_client(served["app"])
    assert _record(page, "p01", old).status_code == 403
    assert _agree(page, "p01").status_code == 200


def test_new_key_needs_a_participant(tmp_path):
    from click.testing import CliRunner

    from siftom.cli import root

    res = CliRunner().invoke(root, ["collect", "--out", str(tmp_path / "ds"), "--new-key"])
    assert res.exit_code == 2 and "--participant" in res.output


@pytest.mark.parametrize("participant", [None, "p01"])
def test_the_first_agreement_still_gets_a_key(tmp_path, participant):
    page = _page(tmp_path / "ds", participant)
    r = _agree(page, "p01")
    assert r.status_code == 200 and len(r.json()["key"]) >= 32
