"""The people pages: each participant and annotator has an unguessable secret, and nobody can
read or write another's recordings or answers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from siftom.cli.people import _access
from siftom.people.annotate import AnnotateOptions
from siftom.people.collect import CollectOptions
from siftom.service.annotate_app import create_annotate_app
from siftom.service.collect_app import create_collect_app
from siftom.speech.audio import wav_bytes
from support.client import local_client


def _voice(f: float = 200.0) -> bytes:
    t = np.arange(16000) / 16000
    return wav_bytes((0.3 * np.sin(2 * np.pi * f * t)).astype(np.float32))


def _record(c, pid: str, key: str | None, index: int = 0, reference: str = "the milk please"):
    data = {"participant": pid, "index": str(index), "reference": reference}
    if key is not None:
        data["key"] = key
    return c.post("/api/recordings", data=data, files={"audio": ("r.wav", _voice())})


@pytest.fixture
def dataset(tmp_path):
    """A recorded folder with two participants' recordings of one kitchen scenario."""
    c = local_client(create_collect_app(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1)))
    for pid in ("p01", "p02"):
        key = c.post("/api/participants", json={"participant": pid, "agree": True}).json()["key"]
        _record(c, pid, key).raise_for_status()
    return tmp_path / "ds"


def test_a_participant_cannot_record_for_another(tmp_path):
    c = local_client(create_collect_app(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1)))
    p01 = c.post("/api/participants", json={"participant": "p01", "agree": True}).json()
    p02 = c.post("/api/participants", json={"participant": "p02", "agree": True}).json()
    assert len(p01["key"]) >= 32 and p01["key"] != p02["key"]
    assert _record(c, "p01", p01["key"]).status_code == 201
    manifest = (tmp_path / "ds" / "manifest.jsonl").read_text()
    for key in (None, "", p02["key"], "x" * 32):  # no key, or someone else's
        r = _record(c, "p01", key, reference="overwritten")
        assert r.status_code == 403 and "key" in r.json()["detail"], (key, r.text)
    assert (tmp_path / "ds" / "manifest.jsonl").read_text() == manifest  # nothing changed
    # taking over an id that has started needs its key
    r = c.post("/api/participants", json={"participant": "p01", "agree": True})
    assert r.status_code == 403 and "siftom collect --participant p01" in r.json()["detail"]
    again = c.post("/api/participants", json={"participant": "p01", "agree": True, "key": p01["key"]}).json()
    assert again["key"] == p01["key"] and again["done"] == [0]
    # the folder keeps only a digest of each key
    text = (tmp_path / "ds" / "participants.jsonl").read_text()
    assert p01["key"] not in text and p02["key"] not in text and "key_sha256" in text


def test_collect_for_one_participant_accepts_only_them(tmp_path):
    out = tmp_path / "ds"
    open_page = local_client(create_collect_app(out, CollectOptions(domain="kitchen-v0", scenarios=1)))
    p02 = open_page.post("/api/participants", json={"participant": "p02", "agree": True}).json()["key"]
    page = local_client(create_collect_app(out, CollectOptions(domain="kitchen-v0", scenarios=1,
                                                               participant="p01")))
    r = page.post("/api/participants", json={"participant": "p02", "agree": True, "key": p02})
    assert r.status_code == 403 and "p01" in r.json()["detail"]
    r = _record(page, "p02", p02)  # a valid key of p02 is still not accepted here
    assert r.status_code == 403 and "participant 'p01' only" in r.json()["detail"]
    key = page.post("/api/participants", json={"participant": "p01", "agree": True}).json()["key"]
    assert _record(page, "p01", key).status_code == 201
    # agreeing again without the key takes nothing over, even on p01's own page
    r = page.post("/api/participants", json={"participant": "p01", "agree": True})
    assert r.status_code == 403 and "--new-key" in r.json()["detail"]
    assert _record(page, "p01", key).status_code == 201
    assert not list((out / "audio").glob("*p02*"))


def test_annotator_ids_are_unguessable_and_keys_guard_their_data(dataset, tmp_path):
    app = create_annotate_app(dataset, tmp_path / "ann", AnnotateOptions(per_stimulus=1, per_annotator=1))
    a = local_client(app)
    first = a.post("/api/annotators", json={"agree": True}).json()
    second = a.post("/api/annotators", json={"agree": True}).json()
    ids = [first["annotator"], second["annotator"]]
    assert all(i.startswith("a-") and len(i) == 10 for i in ids) and ids[0] != ids[1]
    assert "a1" not in ids and "a2" not in ids
    assert len(first["key"]) >= 32 and first["key"] != second["key"]
    # the sequential ids of before open nothing, nor does the annotator's id in place of its key
    for handle in ("a1", "a2", ids[0], "a" * 20):
        assert a.get(f"/api/annotators/{handle}/0/audio.wav").status_code in (403, 422), handle
        assert a.post(f"/api/annotators/{handle}/answers",
                      json={"position": 0, "typed": "x", "item": "milk"}).status_code in (403, 422)
    assert a.get(f"/api/annotators/{first['key']}/0/audio.wav").content[:4] == b"RIFF"
    # an answer through B's key is B's, never A's
    assert a.post(f"/api/annotators/{second['key']}/answers",
                  json={"position": 0, "typed": "milk", "item": "milk"}).status_code == 201
    answers = [json.loads(x) for x in (tmp_path / "ann" / "answers.jsonl").read_text().splitlines()]
    assert [x["annotator"] for x in answers] == [ids[1]]
    # coming back under a taken id needs its key
    r = a.post("/api/annotators", json={"annotator": ids[0], "agree": True})
    assert r.status_code == 403 and "taken" in r.json()["detail"]
    back = a.post("/api/annotators", json={"annotator": ids[0], "agree": True, "key": first["key"]}).json()
    assert back["annotator"] == ids[0] and back["key"] == first["key"]
    text = (tmp_path / "ann" / "annotators.jsonl").read_text()
    assert first["key"] not in text and second["key"] not in text


def test_an_annotator_from_before_keys_gets_one_once(dataset, tmp_path):
    ann = tmp_path / "ann"
    app = create_annotate_app(dataset, ann, AnnotateOptions(per_stimulus=1))
    a = local_client(app)
    a.post("/api/annotators", json={"annotator": "old-1", "agree": True}).raise_for_status()
    rec = json.loads((ann / "annotators.jsonl").read_text())
    (ann / "annotators.jsonl").write_text(json.dumps({k: v for k, v in rec.items() if k != "key_sha256"}) + "\n")
    key = a.post("/api/annotators", json={"annotator": "old-1", "agree": True}).json()["key"]
    assert a.get(f"/api/annotators/{key}/next").json()["annotator"] == "old-1"
    assert a.post("/api/annotators", json={"annotator": "old-1", "agree": True}).status_code == 403


def test_people_pages_beyond_loopback_need_a_token(monkeypatch):
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    access, generated = _access("0.0.0.0", None, None, (), ())
    assert generated and access.token and len(access.token) >= 40
    access, generated = _access("127.0.0.1", None, None, (), ())
    assert not generated and access.token is None


def test_the_annotate_page_needs_its_token_when_it_has_one(dataset, tmp_path):
    from siftom.service.access import Access

    app = create_annotate_app(dataset, tmp_path / "ann", AnnotateOptions(per_stimulus=1),
                              Access(token="annotate-token-0123456789"))
    a = local_client(app)
    assert a.post("/api/annotators", json={"agree": True}).status_code == 401
    ok = a.post("/api/annotators", json={"agree": True},
                headers={"Authorization": "Bearer annotate-token-0123456789"})
    assert ok.status_code == 200
