"""The page's microphone, end to end: Chromium records a WAV made by `siftom say` through its fake
capture device; the page transcribes it on the server and shows the transcript and the command.

Chromium flags: --use-fake-device-for-media-stream (a fake microphone),
--use-fake-ui-for-media-stream (grant the permission prompt), and
--use-file-for-fake-audio-capture=FILE%noloop (the microphone plays FILE once, then silence).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread

CHROMIUM = "/usr/bin/chromium"  # as in test_browser.py
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
ROOT = Path(__file__).parents[2]
SPOKEN = "can you pass me the sugar"

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not Path(CHROMIUM).exists() and shutil.which("chromium") is None,
                       reason=f"needs Debian chromium at {CHROMIUM}: sudo apt-get install -y chromium"),
]


def inferred(page) -> None:
    from playwright.sync_api import expect

    expect(page.locator("#status")).to_have_text(re.compile(r"^inferred"), timeout=60_000)


def _say(text: str, out: Path) -> float:
    """`siftom say TEXT -o OUT` as a user would run it, with one second of silence after; seconds long."""
    import numpy as np
    import soundfile as sf

    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-m", "siftom.cli", "say", text, "-o", str(out)], env=env,
                         capture_output=True, text=True, timeout=120)
    if res.returncode != 0:
        pytest.skip(f"siftom say failed (no TTS voice?): {res.stderr.strip()[-300:]}")
    x, rate = sf.read(out, dtype="float32")
    pad = np.zeros(rate // 2, dtype=np.float32)
    sf.write(out, np.concatenate([pad, x, pad, pad]), rate, subtype="PCM_16")  # lead-in and tail of silence
    return (len(x) + 3 * len(pad)) / rate


def test_recorded_speech_gives_the_transcript_and_the_command(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")
    wav = tmp_path / "sugar.wav"
    seconds = _say(SPOKEN, wav)
    args = [*CHROMIUM_ARGS, "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
            f"--use-file-for-fake-audio-capture={wav}%noloop", "--autoplay-policy=no-user-gesture-required"]
    with serve_in_thread(create_app(tmp_path / "data")) as url, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=args, headless=True)
        try:
            page = browser.new_context(permissions=["microphone"]).new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"{url}/?scenario=kitchen-cereal-v0")
            page.wait_for_selector("body[data-ready='1']", timeout=20_000)
            page.click("#record")
            sync_api.expect(page.locator("#record")).to_have_text(re.compile("Stop"), timeout=10_000)
            time.sleep(seconds + 0.5)  # let the fake microphone play the whole file
            page.click("#record")
            inferred(page)
            heard = page.locator("#instruction").input_value()
            assert "sugar" in heard, heard  # the transcript came back from the server's ASR
            assert page.locator("#nbest li").count() >= 1
            assert page.locator("#command").inner_text() == "fetch(sugar)"
            from siftom.likelihood.whisper_factor import whisper_available

            if whisper_available():  # the page scores the recording itself and says what Whisper heard
                assert page.locator("#acoustic").is_checked()
                assert "pass me the" in page.locator("#whisper").inner_text()  # its words, sugar or not
            assert errors == []
        finally:
            browser.close()


@pytest.mark.parametrize("button, label", [("#record", "Record"), ("#stream", "Listen")])
def test_a_denied_microphone_is_explained(tmp_path, button, label):
    """As on the recording page: what went wrong and how to fix it, in a role=alert region."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")
    expect = sync_api.expect
    args = [*CHROMIUM_ARGS, "--use-fake-device-for-media-stream"]  # a device, but no permission granted
    with serve_in_thread(create_app(tmp_path / "data")) as url, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=args, headless=True)
        try:
            page = browser.new_context().new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"{url}/?scenario=kitchen-cereal-v0")
            page.wait_for_selector("body[data-ready='1']", timeout=20_000)
            page.click(button)
            alert = page.locator("#alert")
            expect(alert).to_be_visible(timeout=10_000)
            expect(alert).to_have_text(re.compile(rf"microphone is blocked.*Allow the microphone.*press {label} again"))
            assert alert.get_attribute("role") == "alert"
            expect(page.locator(button)).not_to_have_text(re.compile("Stop"))  # nothing left running
            assert errors == []
        finally:
            browser.close()
