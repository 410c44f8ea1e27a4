"""The token against someone who guesses it: no short tokens, wrong guesses slowed down per
address, and ``/healthz`` saying whether a token is set without showing it (docs/security.md)."""

from __future__ import annotations

import json
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.testclient import WebSocketDenialResponse

from siftom.errors import OptionsError
from siftom.options import check_token
from siftom.service.access import Access, AccessGuard
from siftom.service.app import create_app
from siftom.service.runtime import ServiceSettings
from support.client import local_client

TOKEN = "k2Jq9-hostile-access-token-long-enough"


# ----- the token's length ------------------------------------------------------------------------

@pytest.mark.parametrize("short", ["a", "secret", "tok", "fifteen-chars-x"])
def test_a_short_token_is_refused_with_how_to_make_one(short):
    with pytest.raises(OptionsError) as exc:
        check_token(short, "--token")
    msg = str(exc.value)
    assert "--token" in msg and "at least 16" in msg and "secrets.token_urlsafe" in msg
    assert "\n" not in msg
    with pytest.raises(OptionsError, match="too short"):
        Access(token=short)
    with pytest.raises(OptionsError, match="too short"):
        ServiceSettings(token=short, likelihoods=("phonetic",))


def test_a_sixteen_character_token_is_taken():
    assert check_token(" sixteen-chars-xy\n") == "sixteen-chars-xy"


def test_serve_refuses_a_one_character_token(monkeypatch, capsys):
    import uvicorn

    import siftom.service.app as app_module
    from siftom.cli import main

    def no_app(*args: Any, **kw: Any) -> Any:
        raise AssertionError("the server must not be built with a one-character token")

    monkeypatch.setattr(app_module, "create_app", no_app)
    monkeypatch.setattr(uvicorn, "run", no_app)
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    assert main(["serve", "--host", "0.0.0.0", "--token", "x"]) != 0
    err = capsys.readouterr().err
    assert "--token is too short" in err and err.count("\n") == 1


# ----- wrong guesses are throttled per address ---------------------------------------------------

class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


async def _ok_app(scope: Any, receive: Any, send: Any) -> None:
    if scope["type"] == "websocket":
        await receive()
        await send({"type": "websocket.accept"})
        await send({"type": "websocket.close", "code": 1000})
        return
    await send({"type": "http.response.start", "status": 200, "headers": [(b"content-type", b"text/plain")]})
    await send({"type": "http.response.body", "body": b"ok"})


def _guarded(clock: Clock, client: tuple[str, int] = ("203.0.113.7", 5000), **kw: Any) -> tuple[AccessGuard, TestClient]:
    guard = AccessGuard(_ok_app, Access(token=TOKEN), clock=clock, **kw)
    return guard, TestClient(guard, base_url="http://127.0.0.1:8000", client=client)


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def test_wrong_guesses_past_the_budget_get_429_with_retry_after():
    clock = Clock()
    _, c = _guarded(clock)
    codes = [c.get("/v1/scenarios", headers=_bearer(f"guess-{i:012d}")).status_code for i in range(50)]
    assert codes[:10] == [401] * 10
    assert set(codes[10:]) == {429}
    r = c.get("/v1/scenarios", headers=_bearer("guess-once-more-000"))
    assert r.status_code == 429
    assert r.headers["content-type"].startswith("application/problem+json")
    assert 1 <= int(r.headers["retry-after"]) <= 60
    detail = r.json()["detail"]
    assert "10" in detail and "60" in detail and "\n" not in detail


def test_throttled_guesses_are_not_compared(monkeypatch):
    from siftom.service import access as access_module

    clock = Clock()
    _, c = _guarded(clock)
    for i in range(10):
        c.get("/", headers=_bearer(f"guess-{i:012d}"))
    seen: list[bytes] = []
    real = access_module.secrets.compare_digest

    def spy(a: bytes, b: bytes) -> bool:
        seen.append(a)
        return real(a, b)

    monkeypatch.setattr(access_module.secrets, "compare_digest", spy)
    assert c.get("/", headers=_bearer(TOKEN)).status_code == 429
    assert c.get(f"/?token={TOKEN}").status_code == 429
    assert seen == []


def test_the_right_token_works_again_after_the_window():
    clock = Clock()
    _, c = _guarded(clock)
    for i in range(20):
        c.get("/", headers=_bearer(f"guess-{i:012d}"))
    assert c.get("/", headers=_bearer(TOKEN)).status_code == 429
    clock.now += 61
    assert c.get("/", headers=_bearer(TOKEN)).status_code == 200


def test_the_window_slides():
    clock = Clock()
    _, c = _guarded(clock)
    for i in range(9):
        assert c.get("/", headers=_bearer(f"guess-{i:012d}")).status_code == 401
    clock.now += 59
    assert c.get("/", headers=_bearer("guess-number-ten-x")).status_code == 401  # the 10th
    assert c.get("/", headers=_bearer("guess-number-11-xx")).status_code == 429
    clock.now += 2  # the first nine are out of the window now, the 10th is not
    assert c.get("/", headers=_bearer("guess-again-000000")).status_code == 401


def test_other_addresses_are_not_throttled_and_right_tokens_do_not_count():
    clock = Clock()
    guard, c = _guarded(clock)
    for _ in range(30):
        assert c.get("/", headers=_bearer(TOKEN)).status_code == 200
    for i in range(12):
        c.get("/", headers=_bearer(f"guess-{i:012d}"))
    other = TestClient(guard, base_url="http://127.0.0.1:8000", client=("198.51.100.2", 6000))
    assert other.get("/", headers=_bearer(TOKEN)).status_code == 200
    assert other.get("/", headers=_bearer("wrong-but-first-one")).status_code == 401


def test_requests_without_a_token_are_not_counted():
    clock = Clock()
    _, c = _guarded(clock)
    for _ in range(30):
        assert c.get("/v1/scenarios").status_code == 401
    assert c.get("/", headers=_bearer(TOKEN)).status_code == 200


def test_a_throttled_websocket_is_refused():
    clock = Clock()
    _, c = _guarded(clock)
    for i in range(10):
        c.get("/", headers=_bearer(f"guess-{i:012d}"))
    with pytest.raises(WebSocketDenialResponse) as exc, c.websocket_connect(
            "ws://127.0.0.1:8000/v1/stream", headers=_bearer(TOKEN)) as ws:
        ws.receive_text()
    assert exc.value.status_code == 429 and exc.value.headers["retry-after"]


def test_memory_is_bounded_by_the_tracked_addresses():
    clock = Clock()
    guard = AccessGuard(_ok_app, Access(token=TOKEN), clock=clock, max_clients=50)
    for n in range(300):
        c = TestClient(guard, base_url="http://127.0.0.1:8000", client=(f"10.0.{n // 256}.{n % 256}", 1))
        c.get("/", headers=_bearer("wrong-guess-000000"))
    assert guard.tracked_clients() <= 50


# ----- /healthz says whether a token is set, never its value -------------------------------------

@pytest.fixture(scope="module")
def app_with_token(tmp_path_factory):
    app = create_app(tmp_path_factory.mktemp("hostile"), ServiceSettings(token=TOKEN, likelihoods=("phonetic",)))
    with local_client(app, base_url="http://127.0.0.1:8000", raise_server_exceptions=False) as c:
        yield c


def test_healthz_says_the_token_is_set_without_its_value(app_with_token, monkeypatch):
    monkeypatch.delenv("SIFTOM_SERVICE_TOKEN", raising=False)
    body = app_with_token.get("/healthz", headers=_bearer(TOKEN)).json()
    assert body["settings"]["service.token"] == "set"
    assert TOKEN not in json.dumps(body)


def test_healthz_says_none_without_a_token(client):
    body = client.get("/healthz").json()
    assert body["settings"]["service.token"] is None
