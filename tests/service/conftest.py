"""Fixtures for the service tests: one app per session (its caches make later tests fast)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

if os.environ.get("CI", "").strip().lower() in ("true", "1", "yes"):
    # CI must not skip the service tests for a missing install step: fail to import instead.
    import fastapi  # noqa: F401
    import httpx  # noqa: F401
pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")
pytest.importorskip("httpx", reason="needs httpx (the dev extra)")

from fastapi.testclient import TestClient

from siftom.service.app import create_app  # noqa: E402
from siftom.service.runtime import ServiceSettings  # noqa: E402
from support.client import local_client  # noqa: E402

SMALL_BODY = 256 * 1024  # above a short recording, small enough to exceed cheaply


@pytest.fixture(scope="session")
def app(tmp_path_factory: pytest.TempPathFactory):
    # a cold first recording (recogniser, Whisper, caches) takes longer than 20 s on a loaded machine
    return create_app(tmp_path_factory.mktemp("serve"), ServiceSettings(max_body_bytes=SMALL_BODY, max_audio_seconds=5.0,
                                                                          request_timeout_s=120.0))


@pytest.fixture(scope="session")
def client(app) -> Iterator[TestClient]:
    with local_client(app, raise_server_exceptions=False) as c:
        yield c


@pytest.fixture(autouse=True)
def _keep_umask():
    """A command run in-process (CliRunner) may set the umask of the process (the servers make
    their files private); give the next test the umask it had."""
    old = os.umask(0o022)
    os.umask(old)
    yield
    os.umask(old)
