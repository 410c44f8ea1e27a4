"""Host allow-list (DNS rebinding) and Origin checks (pages of other sites) on every server."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient
from starlette.testclient import WebSocketDenialResponse
from starlette.websockets import WebSocketDisconnect

from siftom.cli import main, root
from siftom.cli.service import access_for
from siftom.errors import OptionsError
from siftom.people.collect import CollectOptions
from siftom.service.access import Access, normal_origin, split_host
from siftom.service.app import create_app
from siftom.service.collect_app import create_collect_app
from siftom.service.runtime import ServiceSettings
from siftom.service.stream_settings import CLOSE_UNKNOWN_SESSION
from siftom.speech.audio import wav_bytes
from support.client import local_client

NO_SESSION = "0123456789abcdef0123456789abcdef"
EVIL = "http://evil.example"


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    return create_app(tmp_path_factory.mktemp("hosts"),
                      ServiceSettings(likelihoods=("phonetic",), allowed_hosts=("robot-hub.local",),
                                      allowed_origins=("https://studio.example",)))


def _client(app, host: str) -> TestClient:
    return local_client(app, base_url=f"http://{host}", raise_server_exceptions=False)


def test_a_foreign_host_header_is_a_400_naming_the_fix(app):
    c = _client(app, "attacker.example")
    for path in ("/v1/scenarios", "/healthz", "/"):
        r = c.get(path)
        assert r.status_code == 400, path
        assert r.headers["content-type"].startswith("application/problem+json")
        detail = r.json()["detail"]
        assert "attacker.example" in detail and "DNS rebinding" in detail and "--allow-host attacker.example" in detail
    assert c.post("/v1/sessions/from-scenario", json={"scenario": "kitchen-cereal-v0"}).status_code == 400


@pytest.mark.parametrize("host", ["localhost:8000", "127.0.0.1:8000", "[::1]:8000", "192.168.1.5:8000",
                                  "robot-hub.local:8000", "LOCALHOST"])
def test_loopback_addresses_and_allowed_names_are_answered(app, host):
    assert _client(app, host).get("/v1/scenarios").status_code == 200


def test_a_websocket_with_a_foreign_host_is_refused_before_the_handshake(app):
    c = _client(app, "attacker.example")
    with pytest.raises(WebSocketDenialResponse) as exc, c.websocket_connect(f"/v1/sessions/{NO_SESSION}/listen"):
        pass
    assert exc.value.status_code == 400


def test_a_post_from_another_origin_is_a_403(app):
    c = _client(app, "localhost:8000")
    for origin in (EVIL, "null", "http://localhost:3000", "http://localhost.evil.example:8000"):
        r = c.post("/v1/sessions/from-scenario", json={"scenario": "kitchen-cereal-v0"}, headers={"Origin": origin})
        assert r.status_code == 403, origin
        assert "--allow-origin" in r.json()["detail"]
    for method in ("PUT", "PATCH", "DELETE"):
        assert c.request(method, f"/v1/sessions/{NO_SESSION}", headers={"Origin": EVIL}).status_code == 403


def test_same_origin_allowed_origins_and_no_origin_pass(app):
    c = _client(app, "localhost:8000")
    for headers in ({}, {"Origin": "http://localhost:8000"}, {"Origin": "https://studio.example"}):
        r = c.post("/v1/sessions/from-scenario", json={"scenario": "no-such-scenario"}, headers=headers)
        assert r.status_code == 422, headers  # past the guard: the endpoint answers
    # reads are not state-changing: the browser's same-origin policy keeps their answers from the page
    assert c.get("/v1/scenarios", headers={"Origin": EVIL}).status_code == 200


def test_a_websocket_from_another_origin_does_not_open(app):
    c = _client(app, "localhost:8000")
    url = f"/v1/sessions/{NO_SESSION}/listen"
    with pytest.raises(WebSocketDenialResponse) as exc, c.websocket_connect(url, headers={"Origin": EVIL}):
        pass
    assert exc.value.status_code == 403
    with pytest.raises(WebSocketDisconnect) as closed, \
            c.websocket_connect(url, headers={"Origin": "http://localhost:8000"}) as ws:
        ws.receive_text()
    assert closed.value.code == CLOSE_UNKNOWN_SESSION  # same origin: the endpoint itself answers


def _voice() -> bytes:
    t = np.arange(16000) / 16000
    return wav_bytes((0.3 * np.sin(2 * np.pi * 200 * t)).astype(np.float32))


def test_collect_page_refuses_a_cross_site_upload(tmp_path):
    c = TestClient(create_collect_app(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1)),
                   base_url="http://localhost:8010")
    assert c.post("/api/participants", json={"participant": "p01", "agree": True}).status_code == 200
    form = {"participant": "p01", "index": "0", "reference": "overwritten"}
    r = c.post("/api/recordings", data=form, files={"audio": ("r.wav", _voice())}, headers={"Origin": EVIL})
    assert r.status_code == 403
    assert not list((tmp_path / "ds").rglob("*.wav"))
    assert TestClient(c.app, base_url="http://evil.example").get("/api/collection").status_code == 400


def test_parsing_helpers():
    assert split_host("[::1]:8000") == ("::1", "8000")
    assert split_host("Example.ORG.") == ("example.org", "")
    assert normal_origin("HTTP://Localhost:80") == "http://localhost"
    assert normal_origin("null") is None and normal_origin("http://x/path") is None


def test_malformed_allow_values_are_one_line_errors():
    with pytest.raises(OptionsError, match="--allow-host"):
        Access(hosts=("http://robot:80/",))
    with pytest.raises(OptionsError, match="--allow-origin"):
        Access(origins=("robot.local",))
    assert "myrobot" in access_for("myrobot", None, (), ()).hosts  # the bound host is allowed
    assert access_for("0.0.0.0", "t" * 20, (), ()).hosts  # a wildcard: this machine's name


def test_serve_reports_a_malformed_allow_host(tmp_path: Path, capsys):
    assert main(["serve", "--allow-host", "http://x/", "--data-dir", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert "--allow-host" in err and "Traceback" not in err
    assert not (tmp_path / "d").exists()  # refused before anything was written


def test_serve_help_lists_the_guards():
    out = CliRunner().invoke(root, ["serve", "--help"]).output
    assert "--allow-host" in out and "--allow-origin" in out and "--token-file" in out


def test_healthz_through_a_foreign_host_leaks_nothing(app):
    r = _client(app, "rebind.attacker.example").get("/healthz")
    assert r.status_code == 400 and "settings" not in json.dumps(r.json())
