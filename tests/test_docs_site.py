"""The documentation site builds with --strict; the version is one number everywhere."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

import siftom
from siftom.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The documentation site, built once with --strict for the tests below."""
    pytest.importorskip("mkdocs", reason="needs the docs extra: pip install 'siftom[docs]'")
    out = tmp_path_factory.mktemp("docs") / "site"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), NO_MKDOCS_2_WARNING="1")
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(out)],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    return out


def test_mkdocs_builds_strict(site: Path) -> None:
    http = (site / "reference" / "http.html").read_text(encoding="utf-8")
    assert "/v1/sessions" in http and "/v1/infer" in http  # the endpoint table from the OpenAPI schema
    assert '"openapi"' in (site / "reference" / "openapi.json").read_text(encoding="utf-8")
    assert "siftom infer" in (site / "reference" / "cli.html").read_text(encoding="utf-8")
    assert "make_instruction" in (site / "reference" / "python.html").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs" / "tutorials").glob("*.md")):
        assert (site / "tutorials" / f"{page.stem}.html").is_file(), page.name


class _Links(HTMLParser):
    """The href/src of every element of one page, and the ids a link's #fragment can point at."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[tuple[str, str]] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if value and (name == "id" or (tag == "a" and name == "name")):
                self.ids.add(value)
            if value is not None and name in ("href", "src"):
                self.links.append((tag, value))


def test_site_works_opened_from_disk(site: Path) -> None:
    """Every internal link names an existing file (no folder URLs), fragments exist, nothing is fetched."""
    pages: dict[Path, _Links] = {}
    for html in sorted(site.rglob("*.html")):
        parser = _Links()
        parser.feed(html.read_text(encoding="utf-8"))
        pages[html.resolve()] = parser
    assert len(pages) > 30
    broken, remote = [], []
    for html, parser in pages.items():
        page = html.relative_to(site.resolve())
        for tag, url in parser.links:
            parts = urlsplit(url)
            if parts.scheme or parts.netloc:  # links out are fine; loading a script or style from afar is not
                if tag in ("script", "link", "img", "iframe") and parts.scheme in ("http", "https", ""):
                    remote.append(f"{page}: {url}")
                continue
            if parts.path.startswith("/") and page.name != "404.html":  # only the server's 404 page is absolute
                broken.append(f"{page}: {url} (absolute: breaks opened from disk)")
                continue
            base = site if parts.path.startswith("/") else html.parent
            target = (base / unquote(parts.path).lstrip("/")).resolve() if parts.path else html
            if not target.is_file():
                broken.append(f"{page}: {url}")
            elif parts.fragment and target in pages and unquote(parts.fragment) not in pages[target].ids:
                broken.append(f"{page}: {url} (no such anchor)")
    assert not broken, "\n".join(broken[:40])
    assert not remote, "\n".join(remote[:40])
    # Search from file:// needs the index as a script and the worker shim shipped with the site.
    assert (site / "search" / "search_index.js").is_file()
    assert (site / "js" / "iframe-worker-shim.js").is_file()


def test_cli_reference_shows_no_sentinel_default(site: Path) -> None:
    """Options declared without a default (--help, --version, plain flags) get an empty Default cell."""
    cli = (site / "reference" / "cli.html").read_text(encoding="utf-8")
    assert "--version" in cli and "--help" in cli
    assert "Sentinel" not in cli and "UNSET" not in cli
    assert "_required" not in cli


def test_version_is_one_number(capsys: pytest.CaptureFixture[str]) -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["version"] == siftom.__version__
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"siftom {siftom.__version__}"
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert re.search(rf"^## \[{re.escape(siftom.__version__)}\]", changelog, re.MULTILINE)
