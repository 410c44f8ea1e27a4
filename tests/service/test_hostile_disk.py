"""A disk short of room when the server starts still gets the reserve that keeps DELETE working
once it is full; a disk too short even for that is logged, and a DELETE that then finds no room
is a 507 that says to free space, not that DELETE works on a full disk."""

from __future__ import annotations

import json
import logging
import sqlite3
from collections import namedtuple
from pathlib import Path
from typing import Any

import pytest

from siftom.service.app import create_app
from siftom.service.diskfull import RESERVE_BYTES
from siftom.service.store import SessionStore
from support.client import local_client

ROOT = Path(__file__).parents[2]
WORLD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
WRITES = ("INSERT", "UPDATE", "DELETE", "REPLACE")
Usage = namedtuple("Usage", "total used free")


def _free(monkeypatch: pytest.MonkeyPatch, free: int) -> None:
    import siftom.service.store as store_module

    monkeypatch.setattr(store_module.shutil, "disk_usage", lambda _p: Usage(10 * 2**30, 10 * 2**30 - free, free))


@pytest.mark.parametrize("free_mib", [1.5, 2, 3.9])
def test_a_reserve_is_kept_with_little_room_at_start(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     free_mib: float) -> None:
    _free(monkeypatch, int(free_mib * 2**20))
    store = SessionStore(tmp_path / "s.sqlite3")
    try:
        assert store.reserve.is_file() and store.reserve.stat().st_size == RESERVE_BYTES
    finally:
        store.close()


class AlwaysFull:
    """A connection on a disk with no room at all: every write fails as SQLite's full disk."""

    def __init__(self, db: Any) -> None:
        self.db, self.full = db, False

    def execute(self, sql: str, *args: Any) -> Any:
        if self.full and sql.lstrip().upper().startswith(WRITES):
            raise sqlite3.OperationalError("database or disk is full")
        return self.db.execute(sql, *args)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.db, name)


def test_no_room_at_start_is_logged_and_a_failed_delete_says_to_free_space(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    _free(monkeypatch, RESERVE_BYTES // 2)
    with caplog.at_level(logging.WARNING, logger="siftom.service"):
        app = create_app(tmp_path / "data")
    store = app.state.sessions.store
    assert not store.reserve.exists()
    assert any("no room is kept for deleting sessions" in r.getMessage() for r in caplog.records)
    disk = AlwaysFull(store._db)
    store._db = disk
    try:
        with local_client(app, raise_server_exceptions=False) as c:
            sid = c.post("/v1/sessions", json={"world": WORLD}).json()["id"]
            disk.full = True
            r = c.post("/v1/sessions", json={"world": WORLD})
            assert r.status_code == 507 and "DELETE" in r.json()["detail"]
            r = c.delete(f"/v1/sessions/{sid}")
            assert r.status_code == 507, r.text[:300]
            detail = r.json()["detail"]
            assert "works on a full disk" not in detail and "free space" in detail and "DELETE again" in detail
            disk.full = False  # room again: the same DELETE goes through
            assert c.delete(f"/v1/sessions/{sid}").status_code == 204
    finally:
        store._db = disk.db

