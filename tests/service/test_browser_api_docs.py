"""/docs in headless chromium: Swagger UI renders every endpoint and asks no other host for anything."""

from __future__ import annotations

import shutil
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread

CHROMIUM = "/usr/bin/chromium"  # as in test_browser.py
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not Path(CHROMIUM).exists() and shutil.which("chromium") is None,
                       reason=f"needs Debian chromium at {CHROMIUM}: sudo apt-get install -y chromium"),
]


def test_api_docs_render_from_this_server_only(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")
    with serve_in_thread(create_app(tmp_path)) as url, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        try:
            page = browser.new_page()
            hosts: set[str] = set()
            errors: list[str] = []
            page.on("request", lambda req: hosts.add(urlsplit(req.url).netloc)
                    if req.url.startswith("http") else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.goto(f"{url}/docs")
            page.wait_for_selector(".opblock-summary-path", timeout=30_000)
            assert "/v1/infer" in page.content()
        finally:
            browser.close()
    assert hosts == {urlsplit(url).netloc}, hosts
    assert errors == [], errors
