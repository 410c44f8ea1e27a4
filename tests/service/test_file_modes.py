"""Study data and sessions are private: files 0600 in 0700 folders, whatever the umask; a
temporary data folder goes when the server stops."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from siftom.bench.runlock import RunLock
from siftom.people.annotate import AnnotateOptions, Annotation
from siftom.people.collect import Collection, CollectOptions
from siftom.service.app import create_app
from siftom.service.runtime import ServiceSettings
from siftom.speech.audio import wav_bytes
from support.client import local_client

SALAD = (Path(__file__).parents[2] / "docs" / "examples" / "salad" / "world.json").read_text()


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


@pytest.fixture
def open_umask():
    """The common umask 022, under which files are 0644 unless made private."""
    old = os.umask(0o022)
    yield
    os.umask(old)


def _voice() -> bytes:
    t = np.arange(16000) / 16000
    return wav_bytes((0.3 * np.sin(2 * np.pi * 200 * t)).astype(np.float32))


def test_service_files_are_private(tmp_path, open_umask):
    import json

    data = tmp_path / "data"
    app = create_app(data, ServiceSettings(likelihoods=("phonetic",)))
    c = local_client(app)
    sid = c.post("/v1/sessions", json={"world": json.loads(SALAD)}).json()["id"]
    c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "get me the tomato"}).raise_for_status()
    assert c.post(f"/v1/sessions/{sid}/rating", json={"scores": [5, 5, 5]}).status_code == 201
    assert _mode(data) == 0o700 and _mode(data / "maps") == 0o700
    for name in ("sessions.sqlite3", "sessions.sqlite3-wal", "sessions.sqlite3-shm", "ratings.jsonl"):
        if (data / name).exists() or name in ("sessions.sqlite3", "ratings.jsonl"):
            assert _mode(data / name) == 0o600, name
    app.state.runtime.close()
    assert data.is_dir()  # a folder given by the caller stays


def test_recordings_consent_and_answers_are_private(tmp_path, open_umask):
    out = tmp_path / "ds"
    coll = Collection(out, CollectOptions(domain="kitchen-v0", scenarios=1))
    coll.agree("p01")
    stim = coll.save("p01", 0, _voice(), "the milk please")
    assert _mode(out) == 0o700 and _mode(out / "audio") == 0o700
    for p in (out / stim.audio, out / "participants.jsonl", out / "manifest.jsonl", out / "dataset.json"):
        assert _mode(p) == 0o600, p
    ann = Annotation(out, tmp_path / "ann", AnnotateOptions(per_stimulus=1))
    who = ann.join(None).annotator
    ann.answer(who, 0, "milk", "milk", None)
    assert _mode(tmp_path / "ann") == 0o700
    for name in ("plan.json", "annotators.jsonl", "answers.jsonl"):
        assert _mode(tmp_path / "ann" / name) == 0o600, name


def test_the_lock_file_is_private(tmp_path, open_umask):
    with RunLock(tmp_path / "f") as lock:
        assert _mode(lock.path) == 0o600


def test_a_temporary_data_folder_goes_on_close(open_umask):
    app = create_app(None, ServiceSettings(likelihoods=("phonetic",)))
    folder = app.state.runtime.data_dir
    assert folder.is_dir() and _mode(folder) == 0o700
    app.state.runtime.close()
    assert not folder.exists()
    app.state.runtime.close()  # twice is fine


def test_serve_without_data_dir_removes_its_folder_and_runs_private(monkeypatch):
    import uvicorn

    seen: dict = {}

    def fake_run(app, **kw):
        folder = app.state.runtime.data_dir
        seen["folder"] = folder
        seen["mode"] = _mode(folder)
        seen["umask"] = os.umask(0o077)
        os.umask(seen["umask"])

    monkeypatch.setattr(uvicorn, "run", fake_run)
    monkeypatch.setenv("SIFTOM_SERVICE_LIKELIHOODS", "phonetic")
    from siftom.cli import root

    res = CliRunner().invoke(root, ["serve", "--port", "8123"])
    assert res.exit_code == 0, res.output
    assert seen["mode"] == 0o700 and seen["umask"] == 0o077
    assert not seen["folder"].exists()


def test_the_private_helpers_ignore_the_umask(tmp_path, open_umask):
    from siftom.private import append_private, private_dir, write_private_text

    d = private_dir(tmp_path / "a" / "b")
    assert _mode(tmp_path / "a") == 0o700 and _mode(d) == 0o700
    with append_private(d / "x.jsonl") as f:
        f.write("{}\n")
    write_private_text(d / "y.json", "{}")
    assert _mode(d / "x.jsonl") == 0o600 and _mode(d / "y.json") == 0o600
