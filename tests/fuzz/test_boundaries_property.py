"""Property tests at the boundaries: HTTP answers bad input with a 4xx problem document (never a
5xx), and the CLI exits 0 or 2 with a one-line error (never a traceback)."""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzz.test_parsers_property import SALAD, json_values, mutated, script_lines

pytest.importorskip("fastapi", reason="needs the serve extra")
from siftom.cli import main  # noqa: E402
from siftom.service.app import create_app  # noqa: E402
from siftom.service.runtime import ServiceSettings  # noqa: E402
from support.client import local_client  # noqa: E402

FAST = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as d, local_client(
            create_app(Path(d), ServiceSettings(max_body_bytes=64 * 1024)), raise_server_exceptions=False) as c:
        yield c


@pytest.fixture(scope="module")
def sid(client):
    r = client.post("/v1/sessions", json={"world": SALAD})
    assert r.status_code == 201
    return r.json()["id"]


def _problem(r) -> None:
    assert r.status_code < 500, r.text
    if r.status_code >= 400:
        assert r.headers["content-type"].startswith("application/problem+json"), r.text
        assert r.json()["detail"]


def _post_json(client, path: str, body: object):
    # NaN and infinities are sent as Python writes them (not JSON): the server must refuse them cleanly
    return client.post(path, content=json.dumps(body), headers={"content-type": "application/json"})


@FAST
@given(st.one_of(json_values, mutated(SALAD)))
def test_session_worlds(client, world):
    _problem(_post_json(client, "/v1/sessions", {"world": world}))


@FAST
@given(st.lists(script_lines, max_size=3), st.none() | st.integers(-3, 5),
       st.none() | st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=300))
def test_session_actions_and_keys(client, sid, lines, after, key):
    headers = {} if key is None else {"Idempotency-Key": key}
    _problem(client.post(f"/v1/sessions/{sid}/actions", json={"actions": lines, "after": after}, headers=headers))


@FAST
@given(json_values)
def test_instruction_bodies(client, sid, body):
    _problem(_post_json(client, f"/v1/sessions/{sid}/instruction", body))


def _multipart(boundary: str, parts: list[tuple[str, bytes, bool]]) -> bytes:
    out = b""
    for name, data, is_file in parts:
        disp = f'form-data; name="{name}"' + ('; filename="a.wav"' if is_file else "")
        out += f"--{boundary}\r\nContent-Disposition: {disp}\r\n\r\n".encode() + data + b"\r\n"
    return out + f"--{boundary}--\r\n".encode()


fields = st.lists(st.tuples(st.sampled_from(["audio", "scenario", "top", "asr_nbest", "mode", "likelihood", "x"])
                            | st.text(max_size=6), st.binary(max_size=300), st.booleans()), max_size=5)


@FAST
@given(st.one_of(st.binary(max_size=400), fields.map(lambda p: _multipart("bnd", p))),
       st.sampled_from(["/v1/infer", "SESSION"]))
def test_multipart_uploads(client, sid, body, path):
    path = f"/v1/sessions/{sid}/instruction" if path == "SESSION" else path
    _problem(client.post(path, content=body, headers={"content-type": "multipart/form-data; boundary=bnd"}))


def _cli(*args: str) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(list(args))
    return rc, err.getvalue()


@FAST
@given(st.binary(max_size=300) | st.lists(script_lines, max_size=3).map(lambda ls: "\n".join(ls).encode()))
def test_cli_actions_files(data):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "actions.txt"
        p.write_bytes(data)
        rc, err = _cli("infer", "--scenario", "kitchen-cereal-v0", "--actions", str(p), "--transcript", "the milk")
    assert rc in (0, 2) and "Traceback" not in err, err


@FAST
@given(st.one_of(json_values.map(json.dumps).map(str.encode), mutated(SALAD).map(json.dumps).map(str.encode),
                 st.binary(max_size=200)))
def test_cli_world_files(data):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "world.json"
        p.write_bytes(data)
        rc, err = _cli("infer", "--scene", str(p), "--transcript", "the tomato", "--model", "speech-only")
    assert rc in (0, 2) and "Traceback" not in err, err
