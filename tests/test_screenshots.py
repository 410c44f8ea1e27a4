"""`make screenshots` regenerates every picture of a web page in the docs: it runs, with
SIFTOM_UPDATE_DOCS=1, each browser test that writes one (and no test writes one it does not run)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def make_rule(name: str) -> list[str]:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    m = re.search(rf"^{name}:[^\n]*\n((?:\t[^\n]*\n)+)", text, re.MULTILINE)
    assert m, f"no `{name}` target in the Makefile"
    return [ln.strip() for ln in m.group(1).splitlines()]


def test_make_screenshots_runs_every_test_that_updates_the_docs_pictures():
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^\.PHONY:.*\bscreenshots\b", text, re.MULTILINE)
    listed = re.search(r"^SCREENSHOT_TESTS\s*:?=\s*(.+)$", text, re.MULTILINE)
    assert listed, "SCREENSHOT_TESTS is not set"
    files = set(listed.group(1).split())
    (recipe,) = make_rule("screenshots")
    assert recipe.startswith("SIFTOM_UPDATE_DOCS=1 ") and "-m browser" in recipe and "$(SCREENSHOT_TESTS)" in recipe
    marker = 'os.environ.get("SIFTOM_UPDATE_DOCS") == "1"'
    writers = {str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("test_*.py")
               if p.name != Path(__file__).name and marker in p.read_text(encoding="utf-8")}
    assert writers and files == writers, (files, writers)


def test_every_page_picture_in_the_docs_has_a_test_that_takes_it():
    pictures = {"web-demo.png", "collect-page.png", "annotate-page.png"}
    assert all((ROOT / "docs" / "img" / p).is_file() for p in pictures)
    sources = "\n".join((ROOT / f).read_text(encoding="utf-8") for f in
                        re.search(r"^SCREENSHOT_TESTS\s*:?=\s*(.+)$", (ROOT / "Makefile").read_text(encoding="utf-8"),
                                  re.MULTILINE).group(1).split())
    for picture in pictures:
        assert picture in sources, picture
