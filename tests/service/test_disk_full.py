"""A full disk: every refused write is a 507 whose detail says to delete sessions, and DELETE
still works (the store gives up its reserve of room for it)."""

from __future__ import annotations

import errno
import json
import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from siftom.service.app import create_app
from siftom.service.session_records import SessionOptions, SessionSpec
from siftom.service.store import SessionStore
from support.client import local_client

ROOT = Path(__file__).parents[2]
WORLD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
WRITES = ("INSERT", "UPDATE", "DELETE", "REPLACE")


class FullDisk:
    """The store's SQLite connection on a disk with no room but the store's reserve: every write
    fails with SQLite's "database or disk is full" while the reserve file is there."""

    def __init__(self, store: SessionStore) -> None:
        self.store, self.db, self.full = store, store._db, False

    def _check(self, sql: str) -> None:
        reserve = getattr(self.store, "reserve", None)
        if self.full and (reserve is None or reserve.exists()) and sql.lstrip().upper().startswith(WRITES):
            raise sqlite3.OperationalError("database or disk is full")

    def execute(self, sql: str, *args: Any) -> Any:
        self._check(sql)
        return self.db.execute(sql, *args)

    def executemany(self, sql: str, *args: Any) -> Any:
        self._check(sql)
        return self.db.executemany(sql, *args)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.db, name)


@pytest.fixture()
def served(tmp_path: Path) -> Iterator[tuple[TestClient, FullDisk]]:
    app = create_app(tmp_path / "data")
    store = app.state.sessions.store
    disk = FullDisk(store)
    store._db = disk
    with local_client(app, raise_server_exceptions=False) as c:
        yield c, disk
    store._db = disk.db


def _is_507(r: Any) -> None:
    assert r.status_code == 507, r.text[:300]
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["type"] == "urn:siftom:problem:insufficient-storage"
    assert "DELETE" in body["detail"] and "full" in body["detail"]


def test_writes_on_a_full_disk_are_507_and_delete_still_works(served: tuple[TestClient, FullDisk]) -> None:
    c, disk = served
    assert disk.store.reserve.exists()  # made when the store opened (the test disk has room)
    sids = [c.post("/v1/sessions", json={"world": WORLD}).json()["id"] for _ in range(2)]
    disk.full = True
    _is_507(c.post("/v1/sessions", json={"world": WORLD}))
    _is_507(c.post(f"/v1/sessions/{sids[0]}/actions", json={"actions": ["walk(human, fridge)"]}))
    assert c.get(f"/v1/sessions/{sids[0]}").json()["n_actions"] == 0  # nothing half-written
    r = c.delete(f"/v1/sessions/{sids[0]}", headers={"Idempotency-Key": "close-1"})
    assert r.status_code == 204, r.text[:300]
    assert c.get(f"/v1/sessions/{sids[0]}").status_code == 404
    assert c.delete(f"/v1/sessions/{sids[0]}", headers={"Idempotency-Key": "close-1"}).status_code == 204
    # the reserve's room is used now: the rest of the sessions can be deleted, and work on meanwhile
    assert c.post(f"/v1/sessions/{sids[1]}/actions", json={"actions": ["walk(human, fridge)"]}).status_code == 200
    assert c.delete(f"/v1/sessions/{sids[1]}").status_code == 204


def test_a_disk_full_oserror_is_507(served: tuple[TestClient, FullDisk], monkeypatch: pytest.MonkeyPatch) -> None:
    c, _disk = served

    def no_room(*_args: Any, **_kw: Any) -> Any:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(SessionStore, "create", no_room)
    _is_507(c.post("/v1/sessions", json={"world": WORLD}))
    monkeypatch.setattr(SessionStore, "create", lambda *_a, **_k: (_ for _ in ()).throw(
        sqlite3.OperationalError("database or disk is full")))
    _is_507(c.post("/v1/sessions", json={"world": WORLD}))


def test_the_reserve_comes_back_when_the_disk_has_room(tmp_path: Path) -> None:
    store = SessionStore(tmp_path / "s.sqlite3")
    try:
        assert store.reserve.stat().st_size > 0
        store.reserve.unlink()
        store.create("a", SessionSpec(world={}), SessionOptions())
        assert store.reserve.exists()
    finally:
        store.close()
