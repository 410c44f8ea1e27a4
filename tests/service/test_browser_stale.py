"""Answers in the web page come in the order they were asked for: a late answer to an older
request (a slow server, a long recording) is dropped, never shown over a newer one."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

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


def inferred(page) -> None:
    from playwright.sync_api import expect

    expect(page.locator("#status")).to_have_text(re.compile(r"^inferred"), timeout=30_000)


class HoldSlowAnswer:
    """ASGI wrapper: the answer to a POST /v1/infer whose body holds ``marker`` waits until a later
    request's answer was sent, so it reaches the page last (a slow server, without timing)."""

    def __init__(self, app, marker: str) -> None:
        import threading

        self.app, self.marker = app, marker.encode()
        self.other_answered, self.slow_answered = threading.Event(), threading.Event()

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["path"] != "/v1/infer":
            await self.app(scope, receive, send)
            return
        import anyio.to_thread

        messages, more = [], True
        while more:
            msg = await receive()
            messages.append(msg)
            more = msg.get("more_body", False)
        slow = any(self.marker in m.get("body", b"") for m in messages)
        queued = iter(messages)

        async def replay():
            return next(queued, None) or await receive()

        async def ordered_send(msg):
            if slow and msg["type"] == "http.response.start":
                await anyio.to_thread.run_sync(self.other_answered.wait, 60)
            await send(msg)
            if msg["type"] == "http.response.body" and not msg.get("more_body"):
                (self.slow_answered if slow else self.other_answered).set()

        await self.app(scope, replay, ordered_send)


def test_a_late_answer_does_not_overwrite_a_newer_one(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")
    expect = sync_api.expect
    app = HoldSlowAnswer(create_app(tmp_path), marker="sugar")
    with serve_in_thread(app) as url, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        try:
            pg = browser.new_page()
            errors: list[str] = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(f"{url}/?scenario=kitchen-cereal-v0")
            pg.wait_for_selector("body[data-ready='1']", timeout=20_000)
            pg.fill("#instruction", "can you pass me the sugar")  # asked first, answered last
            pg.click("#infer")
            pg.fill("#instruction", "can you pass me the cereal")
            pg.click("#infer")
            inferred(pg)
            assert pg.locator("#command").inner_text() == "fetch(cereal)"
            assert app.slow_answered.wait(60), "the held answer was never sent"
            expect(pg.locator("body")).to_have_attribute("data-stale", "1", timeout=30_000)  # it came, it was dropped
            assert pg.locator("#command").inner_text() == "fetch(cereal)"
            assert pg.locator("#action").inner_text() == "carries out fetch(cereal)"
            assert errors == []
        finally:
            browser.close()
