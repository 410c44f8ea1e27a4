"""People in the loop, in headless Debian chromium (Playwright), driven like a participant would.

* A participant records two scenarios through the collection page with the keyboard alone;
  the microphone is Chromium's fake capture device playing a WAV made by `siftom say`.
  The folder passes `siftom dataset check`, `siftom dataset mix` adds noisy copies and
  `siftom eval` evaluates it unchanged.
* An annotator answers through the annotation page; `siftom report --human` then shows a
  `human` row next to the models, with its transcription WER.
* A participant rates a session's trial on the rating page; `siftom report --ratings` shows
  the mean rating of the session's model.
* With the microphone permission denied, the page says what went wrong and how to fix it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from siftom.cli import main as siftom
from siftom.people.annotate import AnnotateOptions
from siftom.people.collect import CollectOptions
from siftom.service.annotate_app import create_annotate_app
from siftom.service.collect_app import create_collect_app
from siftom.service.local_server import serve_in_thread

CHROMIUM = "/usr/bin/chromium"  # as in test_browser.py
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
ROOT = Path(__file__).parents[2]
DOCS_IMG = ROOT / "docs" / "img"
SPOKEN = "could you bring me the milk please"
TAKE_S = 1.8  # seconds each recording runs

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not Path(CHROMIUM).exists() and shutil.which("chromium") is None,
                       reason=f"needs Debian chromium at {CHROMIUM}: sudo apt-get install -y chromium"),
]


def _say(text: str, out: Path) -> None:
    """`siftom say TEXT -o OUT` (in this process), with a short silence around it."""
    import soundfile as sf

    if siftom(["say", text, "-o", str(out)]) != 0:
        pytest.skip("siftom say failed (no TTS voice?)")
    x, rate = sf.read(out, dtype="float32")
    pad = np.zeros(rate // 4, dtype=np.float32)
    sf.write(out, np.concatenate([pad, x, pad]), rate, subtype="PCM_16")


def _cli(*args: str, capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    code = siftom(list(args))
    out = capsys.readouterr()
    assert code == 0, f"siftom {' '.join(args)} exited {code}: {out.err[-500:]}"
    return out.out


def tab_to(page, element_id: str, limit: int = 40, selector: str | None = None) -> None:
    """Press Tab until the element (or one matching ``selector``) has the focus: it is reachable
    with the keyboard alone."""
    target = page.locator(selector or f"#{element_id}")
    for _ in range(limit):
        if target.evaluate_all("els => els.includes(document.activeElement)"):
            return
        page.keyboard.press("Tab")
    raise AssertionError(f"{selector or '#' + element_id} is not reachable with Tab")


def _unlabelled(page) -> list[str]:
    """Visible form controls and players without an accessible name (a label or aria-label)."""
    return page.locator("input, select, textarea, audio, button").evaluate_all(
        "els => els.filter(e => e.offsetParent !== null && !(e.labels && e.labels.length)"
        " && !e.getAttribute('aria-label') && !(e.tagName === 'BUTTON' && e.textContent.trim()))"
        ".map(e => e.id || e.outerHTML.slice(0, 60))")


def _screenshot(page, name: str, tmp: Path) -> None:
    """A picture of the page: docs/img/NAME with SIFTOM_UPDATE_DOCS=1, else a temporary file."""
    shot = DOCS_IMG / name if os.environ.get("SIFTOM_UPDATE_DOCS") == "1" else tmp / name
    page.set_viewport_size({"width": 1100, "height": 1000})
    page.screenshot(path=str(shot), full_page=True)
    assert shot.stat().st_size > 10_000  # a real picture of the page


def _launch(pw, *extra: str):
    return pw.chromium.launch(executable_path=CHROMIUM, args=[*CHROMIUM_ARGS, *extra], headless=True)


def _watch(page) -> list[str]:
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    return errors


@pytest.fixture(scope="module")
def sync_api():
    return pytest.importorskip("playwright.sync_api", reason="needs playwright: pip install playwright")


def _record(tmp: Path, browser, expect) -> Path:
    """A participant records two kitchen scenarios with the keyboard alone; the dataset folder."""
    out = tmp / "recorded"
    app = create_collect_app(out, CollectOptions(domain="kitchen-v0", scenarios=2))
    with serve_in_thread(app) as url:
        context = browser.new_context(permissions=["microphone"])
        page = context.new_page()
        errors = _watch(page)
        page.goto(url)
        page.wait_for_selector("body[data-ready='1']", timeout=20_000)
        assert "recorded on this computer only" in page.locator("#consent-text").inner_text()
        assert _unlabelled(page) == []
        tab_to(page, "participant")
        page.keyboard.type("p01")
        tab_to(page, "agree")
        page.keyboard.press("Space")
        tab_to(page, "start")
        page.keyboard.press("Enter")
        for k in range(2):
            expect(page.locator("#task-title")).to_have_text(f"Scenario {k + 1} of 2", timeout=10_000)
            expect(page.locator("#task-title")).to_be_focused()  # the new scenario takes the focus
            assert page.locator("#goal").inner_text().startswith("Your goal: Make")
            assert "robot to bring" in page.locator("#ask").inner_text()
            assert page.locator("#scene-actions li").first.inner_text().startswith("You walked to the ")
            frame = page.locator("#scene-frame")
            expect(frame).to_have_attribute("src", re.compile(r"/frames/\d+\.png$"))
            _wait_image(frame)
            for take in (0.3, TAKE_S) if k == 1 else (TAKE_S,):  # the second scenario is recorded again
                tab_to(page, "record")
                page.keyboard.press("Enter")
                expect(page.locator("#record")).to_have_text(re.compile("Stop"), timeout=10_000)
                time.sleep(take)
                page.keyboard.press("Enter")  # the focus stayed on the button: Stop
                expect(page.locator("#record")).to_have_text(re.compile("Record again"), timeout=10_000)
                expect(page.locator("#take")).to_be_visible(timeout=10_000)
                expect(page.locator("#said")).to_be_focused()
            assert page.locator("#playback").get_attribute("src").startswith("blob:")  # playback offered
            if k == 0:
                assert _unlabelled(page) == []
                _screenshot(page, "collect-page.png", tmp)
            page.keyboard.type(SPOKEN)
            page.keyboard.press("Enter")
        expect(page.locator("#done-title")).to_be_visible(timeout=10_000)
        assert errors == []
        context.close()
    return out


def _wait_image(frame) -> None:
    """Wait until the frame PNG has loaded (rendered on the server on first request)."""
    deadline = time.monotonic() + 30
    while not frame.evaluate("e => e.complete && e.naturalWidth > 0"):
        assert time.monotonic() < deadline, "the scene frame did not load"
        time.sleep(0.1)


def _mix_and_evaluate(recorded: Path, tmp: Path) -> Path:
    """The recorded folder mixed with noise and evaluated (fast models); the results folder."""
    from siftom.bench.evaluate import EvalOptions, evaluate
    from siftom.bench.mix import MixOptions, mix_dataset

    ds, written = mix_dataset(recorded, MixOptions(snrs=(20.0, 10.0, 5.0), seed=3))
    assert written == 6 and len(ds.stimuli) == 8
    res = tmp / "results"
    evaluate(recorded, res, EvalOptions(models=("action-only", "literal-asr")))
    return res


def test_people_in_the_loop(tmp_path, sync_api, capsys):
    """Record, check, mix, evaluate; annotate and rate; one report shows the models, human and ratings."""
    wav = tmp_path / "voice.wav"
    _say(SPOKEN, wav)
    with sync_api.sync_playwright() as pw:
        browser = _launch(pw, "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
                          f"--use-file-for-fake-audio-capture={wav}", "--autoplay-policy=no-user-gesture-required")
        try:
            recorded = _record(tmp_path, browser, sync_api.expect)
            _check_recordings(recorded, capsys)
            evaluated = _mix_and_evaluate(recorded, tmp_path)
            assert "ok: 8 stimuli, 2 scenarios, 1 speakers" in _cli("dataset", "check", str(recorded), capsys=capsys)
            ann = _annotate(recorded, tmp_path, browser, sync_api.expect)
            ratings = _rate(tmp_path, browser, sync_api.expect)
        finally:
            browser.close()
    summary = json.loads(_cli("report", str(evaluated), "--human", str(ann), "--ratings", str(ratings), "--json",
                              "--no-figures", capsys=capsys))
    assert list(summary["models"]) == ["literal-asr", "action-only", "human"] and summary["n_stimuli"] == 8
    assert set(summary["breakdowns"]["snr"]) == {"clean", "20 dB", "10 dB", "5 dB"}
    human = summary["models"]["human"]
    gold = [json.loads(x)["gold_command"] for x in (recorded / "manifest.jsonl").read_text().splitlines()]
    assert human["n"] == 8 and human["accuracy"] == pytest.approx(sum(g == "fetch(milk)" for g in gold) / 8)
    assert human["speedup"] is not None and human["accuracy_ci"][0] <= human["accuracy"] <= human["accuracy_ci"][1]
    assert summary["human"]["answers"] == 8 and 0 < summary["human"]["wer"] < 0.5  # half typed with 2 words missing
    assert summary["ratings"]["siftom"]["n"] == 1 and summary["ratings"]["siftom"]["mean"] == pytest.approx(6.0)
    report = (evaluated / "report.md").read_text()
    assert re.search(r"^\| human \| ", report, re.M) and "## The human baseline" in report
    assert "## Ratings after trials with the robot" in report


def _check_recordings(recorded: Path, capsys) -> None:
    """The recordings are 16 kHz mono speech (the last take) with their manifest lines and consent."""
    import soundfile as sf

    lines = [json.loads(x) for x in (recorded / "manifest.jsonl").read_text().splitlines()]
    assert [d["id"] for d in lines] == ["000-p01-clean", "001-p01-clean"]
    for d in lines:
        assert d["speaker"] == "p01" and d["reference"] == SPOKEN
        assert d["gold_command"].startswith("fetch(") and d["observed_actions"]
        x, rate = sf.read(recorded / d["audio"], dtype="float32")
        info = sf.info(recorded / d["audio"])
        assert rate == 16000 and info.channels == 1 and info.subtype == "PCM_16"
        assert TAKE_S - 0.6 < len(x) / rate < TAKE_S + 2.0, len(x) / rate  # the last take, not the 0.3 s one
        assert np.sqrt(np.mean(x ** 2)) > 0.01  # the fake microphone's speech, not silence
    consent = [json.loads(x) for x in (recorded / "participants.jsonl").read_text().splitlines()]
    assert consent[0]["participant"] == "p01" and consent[0]["agreed"] and "recorded" in consent[0]["consent"]


def _annotate(recorded: Path, tmp: Path, browser, expect) -> Path:
    """Four annotators answer every stimulus once with the keyboard; the annotation folder."""
    ann = tmp / "annotation"
    app = create_annotate_app(recorded, ann, AnnotateOptions(per_stimulus=1, seed=5))
    with serve_in_thread(app) as url:
        for who in range(4):  # 2 recordings x 4 conditions: each annotator hears both, in one condition
            context = browser.new_context()
            page = context.new_page()
            errors = _watch(page)
            page.goto(url)
            page.wait_for_selector("body[data-ready='1']", timeout=20_000)
            tab_to(page, "agree")
            page.keyboard.press("Space")
            tab_to(page, "start")
            page.keyboard.press("Enter")
            for k in range(2):
                expect(page.locator("#task-title")).to_have_text(f"Recording {k + 1} of 2", timeout=10_000)
                assert page.locator("#player").get_attribute("src").endswith("/audio.wav")
                assert page.locator("#goal").count() == 0  # the annotator infers the goal
                assert re.search(r"annotator id is a-[A-Za-z0-9_-]{8}\. To continue later, keep this link .*#key=",
                                 page.locator("#who").inner_text())
                tab_to(page, "play")
                page.keyboard.press("Enter")
                tab_to(page, "typed")
                page.keyboard.type(SPOKEN if who % 2 == 0 else "could you bring me the")
                tab_to(page, "item")
                page.keyboard.type("milk")  # a focused list picks the option typed
                expect(page.get_by_label("What would you bring?")).to_have_value("milk")
                if who == 0 and k == 0:
                    assert _unlabelled(page) == []
                    _screenshot(page, "annotate-page.png", tmp)
                assert page.locator("#count").is_hidden()  # fetch: no count to choose
                tab_to(page, "submit")
                page.keyboard.press("Enter")
            expect(page.locator("#done-title")).to_be_visible(timeout=10_000)
            assert re.search(r"annotator a-[A-Za-z0-9_-]{8}\)", page.locator("#done-text").inner_text())
            assert errors == []
            context.close()
    answers = [json.loads(x) for x in (ann / "answers.jsonl").read_text().splitlines()]
    assert len(answers) == 8 and len({a["id"] for a in answers}) == 8  # every stimulus once
    names = {x["annotator"] for x in answers}
    assert len(names) == 4 and all(a.startswith("a-") for a in names)  # unguessable ids, not a1, a2 ...
    for a in names:  # nobody heard the same recording twice (clean and noisy)
        assert sorted(x["id"][:3] for x in answers if x["annotator"] == a) == ["000", "001"]
    return ann


def _rate(tmp: Path, browser, expect) -> Path:
    """A participant rates a session's trial with the keyboard; the service's ratings.jsonl."""
    import httpx

    from siftom.service.app import create_app

    world = json.loads((ROOT / "docs" / "examples" / "salad" / "world.json").read_text())
    data = tmp / "serve"
    with serve_in_thread(create_app(data)) as url:
        api = httpx.Client(base_url=url, timeout=60)
        sid = api.post("/v1/sessions", json={"world": world}).raise_for_status().json()["id"]
        api.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "can you get me the tomato"}).raise_for_status()
        context = browser.new_context()
        page = context.new_page()
        errors = _watch(page)
        page.goto(f"{url}/rate?session={sid}")
        page.wait_for_selector("body[data-ready='1']", timeout=20_000)
        assert page.locator("#trial").inner_text().startswith(("The robot did: fetch(", "The robot did nothing (heard as fetch("))
        assert page.locator("legend").nth(1).inner_text() == "2. The robot understood what I needed."
        assert _unlabelled(page) == [] and page.locator("input[type=radio]").count() == 21
        tab_to(page, "send")
        page.keyboard.press("Enter")  # nothing chosen: the page says what is missing
        expect(page.locator("#alert")).to_have_text("Choose a rating for statement 1.")
        for k, value in enumerate((6, 5, 7)):
            tab_to(page, "", selector=f"input[name=s{k}]")  # a radio group is one tab stop
            expect(page.locator(f"#s{k}-1")).to_be_focused()
            for _ in range(value - 1):
                page.keyboard.press("ArrowRight")  # radio buttons: arrows move and choose
            expect(page.locator(f"#s{k}-{value}")).to_be_checked()
        tab_to(page, "send")
        page.keyboard.press("Enter")
        expect(page.locator("#done-title")).to_be_visible(timeout=10_000)
        assert errors == []
        context.close()
    return data / "ratings.jsonl"


def test_a_denied_microphone_is_explained(tmp_path, sync_api):
    app = create_collect_app(tmp_path / "denied", CollectOptions(domain="kitchen-v0", scenarios=1, participant="p9"))
    expect = sync_api.expect
    with serve_in_thread(app) as url, sync_api.sync_playwright() as pw:
        browser = _launch(pw, "--use-fake-device-for-media-stream")  # a device, but no permission granted
        try:
            context = browser.new_context()
            page = context.new_page()
            page.goto(url)
            page.wait_for_selector("body[data-ready='1']", timeout=20_000)
            assert page.locator("#participant").input_value() == "p9"
            page.locator("#agree").check()
            page.locator("#start").click()
            expect(page.locator("#task-title")).to_have_text("Scenario 1 of 1", timeout=10_000)
            page.locator("#record").click()
            alert = page.locator("#alert")
            expect(alert).to_be_visible(timeout=10_000)
            expect(alert).to_have_text(re.compile(r"microphone is blocked.*Allow the microphone.*press Record again"))
            assert alert.get_attribute("role") == "alert"
            assert page.locator("#take").is_hidden()  # nothing to save
            assert not (tmp_path / "denied" / "manifest.jsonl").exists()
        finally:
            browser.close()
