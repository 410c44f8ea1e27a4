from __future__ import annotations

import os
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


import pytest  # noqa: E402

# Under CI=true a test that would skip because a tool, a Python package or a data file is
# missing fails instead: a missing install step must not pass silently. Tests that need a
# service the user brings (a live vision/language model endpoint, a GPU) carry these markers
# and are deselected by name (pyproject's addopts).
BROUGHT_BY_USER = ("vlm", "gpu")
MISSING = re.compile(
    r"install|need|require|not found|missing|could not import|no module|absent|not packaged|"
    r"not here|no tts|unavailable|does not exist|cannot find",
    re.IGNORECASE,
)


def on_ci() -> bool:
    """Whether this run is CI (``CI=true``, as CI services set it)."""
    return os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


def _skip_reason(report: pytest.TestReport | pytest.CollectReport) -> str:
    lr = report.longrepr
    if isinstance(lr, tuple) and len(lr) == 3:
        return str(lr[2])
    return str(lr or "")


def missing_resource(report: pytest.TestReport | pytest.CollectReport) -> str | None:
    """The skip reason when ``report`` skipped for something missing, else None."""
    if not report.skipped or hasattr(report, "wasxfail"):
        return None
    reason = _skip_reason(report)
    return reason if MISSING.search(reason) else None


def _fail(report: pytest.TestReport | pytest.CollectReport, reason: str) -> None:
    report.outcome = "failed"
    report.longrepr = (f"CI=true: this test would skip because something is missing ({reason}); "
                       "install it (make setup / make sysdeps) or ship the data with the project")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    outcome = yield
    report = outcome.get_result()
    if not on_ci() or any(item.get_closest_marker(m) for m in BROUGHT_BY_USER):
        return
    reason = missing_resource(report)
    if reason is not None:
        _fail(report, reason)


@pytest.hookimpl(tryfirst=True)
def pytest_collectreport(report: pytest.CollectReport) -> None:
    """A module or folder skipped at collection (``importorskip`` in a conftest) fails too."""
    if not on_ci():
        return
    reason = missing_resource(report)
    if reason is not None:
        _fail(report, reason)


@pytest.fixture()
def fake_openai():
    """A local OpenAI-compatible server (tests/support/fake_openai.py), stopped after the test."""
    from support.fake_openai import FakeOpenAI

    server = FakeOpenAI().start()
    yield server
    server.stop()
