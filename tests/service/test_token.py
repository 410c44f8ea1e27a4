"""A token, as Jupyter does: beyond loopback nobody gets in without it (docs/security.md)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from siftom.cli import root
from siftom.cli.service import resolve_token
from siftom.errors import OptionsError
from siftom.service import access
from siftom.service.access import CLOSE_UNAUTHORIZED, cookie_name
from siftom.service.app import create_app
from siftom.service.runtime import ServiceSettings
from siftom.service.stream_settings import CLOSE_UNKNOWN_SESSION
from siftom.settings import Settings
from support.client import local_client

TOKEN = "k2Jq9-test-token-that-is-long-enough"
NO_SESSION = "0123456789abcdef0123456789abcdef"


@pytest.fixture(scope="module")
def guarded(tmp_path_factory):
    app = create_app(tmp_path_factory.mktemp("tok"), ServiceSettings(token=TOKEN, likelihoods=("phonetic",)))
    with local_client(app, base_url="http://127.0.0.1:8000", raise_server_exceptions=False) as c:
        yield c


def _fresh(client: TestClient) -> TestClient:
    client.cookies.clear()
    return client


def test_without_the_token_every_endpoint_is_401(guarded):
    c = _fresh(guarded)
    for method, path in (("GET", "/v1/scenarios"), ("GET", "/"), ("GET", "/rate"), ("GET", "/openapi.json"),
                         ("POST", "/v1/sessions"), ("POST", "/v1/infer")):
        r = c.request(method, path)
        assert r.status_code == 401, (method, path, r.status_code)
        assert r.headers["content-type"].startswith("application/problem+json")
        assert "Authorization: Bearer" in r.json()["detail"]
        assert r.headers["www-authenticate"].startswith("Bearer")
    r = c.get("/v1/scenarios", headers={"Authorization": "Bearer not-the-token"})
    assert r.status_code == 401 and "wrong" in r.json()["detail"]


def test_bearer_header_gets_in(guarded):
    c = _fresh(guarded)
    assert c.get("/v1/scenarios", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200


def test_the_token_is_compared_in_constant_time(guarded, monkeypatch):
    seen = []
    real = access.secrets.compare_digest

    def spy(a, b):
        seen.append((a, b))
        return real(a, b)

    monkeypatch.setattr(access.secrets, "compare_digest", spy)
    assert _fresh(guarded).get("/v1/scenarios", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    assert seen and all(b == TOKEN.encode() for _, b in seen)


def test_page_url_with_token_sets_a_strict_httponly_cookie_and_drops_the_token(guarded):
    c = _fresh(guarded)
    r = c.get(f"/?token={TOKEN}", headers={"Accept": "text/html"}, follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/"
    cookie = r.headers["set-cookie"]
    assert cookie.startswith(f"{cookie_name(TOKEN)}={TOKEN}")
    assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
    # the browser now loads the page, and its API calls, with the cookie alone
    assert c.get("/", headers={"Accept": "text/html"}).status_code == 200
    assert c.get("/v1/scenarios").status_code == 200
    assert c.get("/rate").status_code == 200


def test_query_token_works_for_api_calls_too(guarded):
    c = _fresh(guarded)
    r = c.get(f"/v1/scenarios?token={TOKEN}")
    assert r.status_code == 200 and "set-cookie" in r.headers


def test_healthz_stays_open_but_reveals_nothing_without_the_token(guarded):
    c = _fresh(guarded)
    body = c.get("/healthz").json()
    assert body == {"status": "ok", "token_required": True}
    full = c.get("/healthz", headers={"Authorization": f"Bearer {TOKEN}"}).json()
    assert "settings" in full and "version" in full and TOKEN not in str(full)


def test_static_files_stay_open(guarded):
    assert _fresh(guarded).get("/static/app.js").status_code == 200


def _ws_close_code(c: TestClient, url: str, headers: dict[str, str] | None = None) -> int:
    with pytest.raises(WebSocketDisconnect) as exc, c.websocket_connect(url, headers=headers or {}) as ws:
        ws.receive_text()
    return exc.value.code


def test_websocket_needs_the_token_by_header_cookie_or_query(guarded):
    c = _fresh(guarded)
    url = f"/v1/sessions/{NO_SESSION}/listen"
    assert _ws_close_code(c, url) == CLOSE_UNAUTHORIZED
    assert _ws_close_code(c, url, {"Authorization": "Bearer wrong"}) == CLOSE_UNAUTHORIZED
    # past the guard, the endpoint itself answers (no such session)
    assert _ws_close_code(c, url, {"Authorization": f"Bearer {TOKEN}"}) == CLOSE_UNKNOWN_SESSION
    assert _ws_close_code(c, url, {"Cookie": f"{cookie_name(TOKEN)}={TOKEN}"}) == CLOSE_UNKNOWN_SESSION
    assert _ws_close_code(c, f"{url}?token={TOKEN}") == CLOSE_UNKNOWN_SESSION


def test_the_token_is_never_shown_in_the_settings(monkeypatch):
    monkeypatch.setenv("SIFTOM_SERVICE_TOKEN", TOKEN)
    st = Settings.load()
    assert st.service.token == TOKEN
    shown = {k: v for k, v, _ in st.show()}
    assert shown["service.token"] == "***"
    assert TOKEN not in repr(st.service)


def test_resolve_token(tmp_path, monkeypatch):
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    assert resolve_token("127.0.0.1", None, None) == (None, False)  # loopback: optional
    assert resolve_token("localhost", "mine-1234-long-enough", None) == ("mine-1234-long-enough", False)
    made, generated = resolve_token("0.0.0.0", None, None)
    assert generated and made is not None and len(made) >= 40
    assert resolve_token("0.0.0.0", None, None)[0] != made
    f = tmp_path / "tok"
    f.write_text(TOKEN + "\n")
    assert resolve_token("0.0.0.0", None, f) == (TOKEN, False)
    monkeypatch.setenv("SIFTOM_TOKEN", "from-env-123-long-enough")
    assert resolve_token("0.0.0.0", None, None) == ("from-env-123-long-enough", False)
    monkeypatch.delenv("SIFTOM_TOKEN")
    assert resolve_token("192.168.1.5", None, None, "from-settings-long-enough") == ("from-settings-long-enough", False)
    with pytest.raises(OptionsError, match="not both"):
        resolve_token("0.0.0.0", "a", f)
    with pytest.raises(OptionsError, match="cannot read the token file"):
        resolve_token("0.0.0.0", None, tmp_path / "missing")
    (tmp_path / "empty").write_text("\n")
    with pytest.raises(OptionsError, match="empty"):
        resolve_token("0.0.0.0", None, tmp_path / "empty")


def _fake_serve(monkeypatch) -> dict:
    """Run ``siftom serve`` up to uvicorn without building the models or listening."""
    import uvicorn

    import siftom.cli.service as service_cli
    import siftom.service.app as app_module

    got: dict = {}

    def fake_create_app(data_dir, settings, observer):
        got["settings"] = settings
        return SimpleNamespace(state=SimpleNamespace(runtime=SimpleNamespace(close=lambda: None)))

    monkeypatch.setattr(app_module, "create_app", fake_create_app)
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: got.update(kw))
    monkeypatch.setattr(service_cli, "check_port", lambda host, port: None)  # a LAN address this machine may lack
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    monkeypatch.delenv("SIFTOM_SERVICE_TOKEN", raising=False)
    return got


def test_serve_beyond_loopback_makes_a_token_and_prints_a_ready_url(monkeypatch):
    got = _fake_serve(monkeypatch)
    res = CliRunner().invoke(root, ["serve", "--host", "192.168.1.5", "--port", "8123"])
    assert res.exit_code == 0, res.output
    token = got["settings"].token
    assert token and len(token) >= 40
    assert f"http://192.168.1.5:8123/?token={token}" in res.output
    assert res.output.count(token) == 2  # the URL, and the header for robots


def test_serve_on_loopback_needs_no_token(monkeypatch):
    got = _fake_serve(monkeypatch)
    res = CliRunner().invoke(root, ["serve", "--port", "8123"])
    assert res.exit_code == 0, res.output
    assert got["settings"].token is None and "token=" not in res.output


def test_serve_takes_a_token_file(monkeypatch, tmp_path: Path):
    got = _fake_serve(monkeypatch)
    (tmp_path / "t").write_text(TOKEN)
    res = CliRunner().invoke(root, ["serve", "--host", "0.0.0.0", "--token-file", str(tmp_path / "t")])
    assert res.exit_code == 0, res.output
    assert got["settings"].token == TOKEN and TOKEN not in res.output  # a given token is not printed
