"""The participant pages' APIs answer mistakes with problem details (no browser needed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from siftom.people.annotate import AnnotateOptions
from siftom.people.collect import CollectOptions
from siftom.service.annotate_app import create_annotate_app
from siftom.service.collect_app import create_collect_app
from siftom.speech.audio import wav_bytes
from support.client import local_client

SALAD = json.loads((Path(__file__).parents[2] / "docs" / "examples" / "salad" / "world.json").read_text())


def _voice() -> bytes:
    t = np.arange(16000) / 16000
    return wav_bytes((0.3 * np.sin(2 * np.pi * 200 * t)).astype(np.float32))


def _problem(r, status: int, text: str) -> None:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    assert text in r.json()["detail"], r.json()["detail"]


def test_collect_api(tmp_path):
    c = local_client(create_collect_app(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1)))
    assert "default-src 'self'" in c.get("/").headers["content-security-policy"]  # nothing loads from elsewhere
    assert c.get("/api/collection").json()["scenarios"] == 1
    form = {"participant": "p1", "index": "0", "reference": "the milk please"}
    _problem(c.post("/api/recordings", data=form, files={"audio": ("r.wav", _voice())}), 422, "has not agreed")
    _problem(c.post("/api/participants", json={"participant": "p1", "agree": False}), 422, "agreement")
    joined = c.post("/api/participants", json={"participant": "p1", "agree": True}).json()
    assert joined["done"] == []
    form["key"] = joined["key"]
    _problem(c.post("/api/recordings", data={**form, "index": "5"}, files={"audio": ("r.wav", _voice())}), 404,
             "no scenario 5")
    _problem(c.post("/api/recordings", data=form, files={"audio": ("r.wav", b"RIFF....")}), 422, "cannot read")
    r = c.post("/api/recordings", data=form, files={"audio": ("r.wav", _voice())})
    assert r.status_code == 201 and r.json()["done"] == [0] and r.json()["id"] == "000-p1-clean"
    _problem(c.get("/api/prompts/0/frames/99.png"), 404, "outside")
    png = c.get("/api/prompts/0/frames/1.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"


def test_annotate_api(tmp_path):
    c = local_client(create_collect_app(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1)))
    key = c.post("/api/participants", json={"participant": "p1", "agree": True}).json()["key"]
    c.post("/api/recordings", data={"participant": "p1", "key": key, "index": "0", "reference": "milk"},
           files={"audio": ("r.wav", _voice())}).raise_for_status()
    a = local_client(create_annotate_app(tmp_path / "ds", tmp_path / "ann", AnnotateOptions(per_stimulus=1)))
    _problem(a.post("/api/annotators", json={"agree": False}), 422, "agreement")
    _problem(a.get("/api/annotators/nobody-with-this-key/next"), 403, "belongs to no annotator")
    v = a.post("/api/annotators", json={"agree": True}).json()
    assert v["annotator"].startswith("a-") and v["form"] == {"verb": "fetch", "classes": v["form"]["classes"],
                                                              "max_count": None}
    assert "milk" in v["form"]["classes"] and "goal" not in v  # the annotator is not told the goal
    k = v["key"]
    assert a.get(f"/api/annotators/{k}/0/audio.wav").content[:4] == b"RIFF"
    _problem(a.post(f"/api/annotators/{k}/answers", json={"position": 0, "typed": "x", "item": "unicorn"}), 422,
             "not in this scene")
    done = a.post(f"/api/annotators/{k}/answers", json={"position": 0, "typed": "milk", "item": "milk"})
    assert done.status_code == 201 and done.json()["done"] is True
    _problem(a.post("/api/annotators", json={"agree": True}), 422, "every assignment is taken")


def test_rating_endpoint(client):
    sid = client.post("/v1/sessions", json={"world": SALAD}).json()["id"]
    assert client.get("/v1/ratings/statements").json()["scale"] == [1, 7]
    _problem(client.post(f"/v1/sessions/{sid}/rating", json={"scores": [1, 2, 9]}), 422, "from 1 to 7")
    assert client.post(f"/v1/sessions/{sid}/rating", json={"scores": [1, 2]}).status_code == 422
    assert client.post("/v1/sessions/nope/rating", json={"scores": [1, 2, 3]}).status_code == 404
    client.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "get me the tomato"})
    r = client.post(f"/v1/sessions/{sid}/rating", json={"scores": [7, 6, 5], "rater": "p3"})
    assert r.status_code == 201 and r.json()["model"] == "siftom" and r.json()["mean"] == 6.0
    assert r.json()["top_command"].startswith("fetch(") and r.json()["action"] in ("act", "ask", "none")
    assert client.get("/rate").headers["content-type"].startswith("text/html")


def test_annotating_a_table_setting_asks_how_many(tmp_path):
    c = local_client(create_collect_app(tmp_path / "ds", CollectOptions(domain="household-table-v0", scenarios=1)))
    key = c.post("/api/participants", json={"participant": "p1", "agree": True}).json()["key"]
    c.post("/api/recordings", data={"participant": "p1", "key": key, "index": "0", "reference": "four bowls please"},
           files={"audio": ("r.wav", _voice())}).raise_for_status()
    a = local_client(create_annotate_app(tmp_path / "ds", tmp_path / "ann", AnnotateOptions(per_stimulus=1)))
    v = a.post("/api/annotators", json={"annotator": "ann-7", "agree": True}).json()
    assert v["annotator"] == "ann-7" and v["form"]["verb"] == "deliver" and v["form"]["max_count"] == 4
    assert v["actions"][0] == "The person walked to the living cabinet."
    k = v["key"]
    _problem(a.post(f"/api/annotators/{k}/answers", json={"position": 0, "typed": "bowls", "item": "bowl"}), 422,
             "how many")
    r = a.post(f"/api/annotators/{k}/answers", json={"position": 0, "typed": "bowls", "item": "bowl", "count": 4})
    assert r.status_code == 201
    answers = [json.loads(x) for x in (tmp_path / "ann" / "answers.jsonl").read_text().splitlines()]
    assert answers == [{**answers[0], "annotator": "ann-7", "id": "000-p1-clean", "command": "deliver(bowl,4)"}]
