"""A damaged ``sessions.sqlite3``: the server does not start on it but says which file and how to
start again (no traceback); damage found while serving is a 500 problem document saying it is
the server's; a stored session that cannot be rebuilt is a 500 naming the session and the way
out (DELETE it), never a 422 blaming the request."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from siftom.service.app import create_app
from siftom.service.store import SessionStore, StoreDamagedError
from support.client import local_client

ROOT = Path(__file__).parents[2]
WORLD = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())


def _filled(folder: Path, n: int = 3) -> list[str]:
    app = create_app(folder)
    try:
        with local_client(app) as c:
            sids = [c.post("/v1/sessions", json={"world": WORLD}).json()["id"] for _ in range(n)]
            for sid in sids:
                assert c.post(f"/v1/sessions/{sid}/actions", json={"actions": ["walk(human, fridge)"]}).status_code == 200
    finally:
        app.state.runtime.close()
    db = sqlite3.connect(folder / "sessions.sqlite3")
    db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    db.close()
    return sids


def _not_a_database(folder: Path) -> None:
    folder.mkdir(parents=True)
    (folder / "sessions.sqlite3").write_bytes(bytes(range(256)) * 32)


def _pages_broken(folder: Path) -> None:
    _filled(folder, 40)
    path = folder / "sessions.sqlite3"
    data = bytearray(path.read_bytes())
    page = int.from_bytes(data[16:18], "big") or 65536
    assert len(data) >= 4 * page
    data[page:3 * page] = bytes([0x5A]) * (2 * page)  # the tables' first pages overwritten
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage", [_not_a_database, _pages_broken])
def test_a_damaged_store_is_a_startup_error_naming_the_file_and_the_fix(tmp_path: Path, damage: Any) -> None:
    folder = tmp_path / "data"
    damage(folder)
    with pytest.raises(StoreDamagedError) as exc:
        SessionStore(folder / "sessions.sqlite3")
    msg = str(exc.value)
    assert str(folder / "sessions.sqlite3") in msg and "aside" in msg and "--data-dir" in msg and "\n" not in msg


def test_serve_on_a_damaged_store_exits_with_one_error_line(tmp_path: Path) -> None:
    folder = tmp_path / "data"
    _not_a_database(folder)
    p = subprocess.run([sys.executable, "-m", "siftom.cli", "serve", "--port", "18998", "--data-dir", str(folder)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr[-2000:]
    assert "Traceback" not in p.stderr
    errors = [ln for ln in p.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "sessions.sqlite3" in errors[0] and "aside" in errors[0]


class DamagedLater:
    """The store's connection once its file is damaged under it: every statement fails as SQLite's
    "database disk image is malformed"."""

    def __init__(self, db: Any) -> None:
        self.db, self.damaged = db, False

    def execute(self, sql: str, *args: Any) -> Any:
        if self.damaged:
            raise sqlite3.DatabaseError("database disk image is malformed")
        return self.db.execute(sql, *args)

    def executemany(self, sql: str, *args: Any) -> Any:
        return self.execute(sql, *args)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.db, name)


@pytest.fixture()
def served(tmp_path: Path) -> Iterator[tuple[Any, Any, Path]]:
    app = create_app(tmp_path / "data")
    try:
        with local_client(app, raise_server_exceptions=False) as c:
            yield c, app, tmp_path / "data"
    finally:
        app.state.runtime.close()


def test_damage_while_serving_is_a_problem_document_saying_it_is_the_servers(served: Any) -> None:
    c, app, _ = served
    sid = c.post("/v1/sessions", json={"world": WORLD}).json()["id"]
    store = app.state.sessions.store
    broken = DamagedLater(store._db)
    store._db, broken.damaged = broken, True
    try:
        for r in (c.delete(f"/v1/sessions/{sid}"), c.post("/v1/sessions", json={"world": WORLD})):
            assert r.status_code == 500 and r.headers["content-type"].startswith("application/problem+json")
            body = r.json()
            assert body["type"] == "urn:siftom:problem:store-damaged"
            assert "nothing in the request is wrong" in body["detail"] and "aside" in body["detail"]
    finally:
        store._db = broken.db


def _rewrite(folder: Path, sql: str, *args: Any) -> None:
    db = sqlite3.connect(folder / "sessions.sqlite3")
    db.execute(sql, args)
    db.commit()
    db.close()


@pytest.mark.parametrize(("sql", "value"), [
    ("UPDATE sessions SET spec = ? WHERE id = ?", '{"world": 5}'),
    ("UPDATE sessions SET options = ? WHERE id = ?", "not json"),
    ("UPDATE actions SET text = ? WHERE session = ?", "fly(human, moon)"),
])
def test_a_stored_row_that_cannot_be_read_is_the_servers_500_not_a_422(tmp_path: Path, sql: str, value: str) -> None:
    folder = tmp_path / "data"
    sid = _filled(folder, 1)[0]
    _rewrite(folder, sql, value, sid)
    app = create_app(folder)
    try:
        with local_client(app, raise_server_exceptions=False) as c:
            r = c.get(f"/v1/sessions/{sid}")
            assert r.status_code == 500, r.text[:300]
            body = r.json()
            assert body["type"] == "urn:siftom:problem:stored-session-unreadable"
            assert sid in body["detail"] and f"DELETE /v1/sessions/{sid}" in body["detail"]
            assert c.post(f"/v1/sessions/{sid}/actions", json={"actions": ["walk(human, fridge)"]}).status_code == 500
            assert c.delete(f"/v1/sessions/{sid}").status_code == 204  # the way out works
            assert c.get(f"/v1/sessions/{sid}").status_code == 404
    finally:
        app.state.runtime.close()
