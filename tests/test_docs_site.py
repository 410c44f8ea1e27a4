"""The documentation site builds with --strict; the version is one number everywhere.

The HTTP reference (reference/http.md) is generated from the service: every route of the app is
on the page, each operation has its request and response fields, and the examples shown are the
answers a fresh server gives (the same status and the same keys when replayed now)."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import tomllib
from html import unescape
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
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


# ----- the HTTP reference ------------------------------------------------------------------------
def load_hook() -> Any:
    spec = importlib.util.spec_from_file_location("siftom_docs_openapi_hook", ROOT / "docs" / "hooks" / "openapi.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def hook() -> Any:
    return load_hook()


@pytest.fixture(scope="module")
def http_page(site: Path) -> str:
    return unescape((site / "reference" / "http.html").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> Any:
    pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")
    pytest.importorskip("httpx", reason="needs httpx (the dev extra)")
    from siftom.service.app import create_app

    return create_app(tmp_path_factory.mktemp("http-ref"))


def test_http_reference_lists_every_route(http_page: str, app: Any) -> None:
    paths = {getattr(r, "path", "").replace(":path}", "}") for r in app.routes}
    assert "/v1/sessions/{session_id}/listen" in paths and "/docs" in paths
    missing = sorted(p for p in paths if f"{p}</code>" not in http_page)
    assert not missing, missing


def test_http_routes_outside_the_schema_say_what_they_are(hook: Any, app: Any) -> None:
    rows = hook.route_rows(app)
    assert {path for _, path, _ in rows} >= {"/", "/docs", "/openapi.json", "/v1/sessions/{session_id}/listen"}
    assert all(text for _, _, text in rows), [path for _, path, text in rows if not text]


def test_http_operations_have_their_fields(http_page: str, app: Any) -> None:
    schema = app.openapi()
    comps = schema["components"]["schemas"]
    for path, ops in schema["paths"].items():
        for method, op in ops.items():
            heading = f"{method.upper()} {path}"
            assert heading in http_page, heading
            section = http_page.split(heading, 1)[1]
            bodies = [*op.get("requestBody", {}).get("content", {}).values(),
                      *(c for code, r in op["responses"].items() if code.startswith("2")
                        for c in r.get("content", {}).values())]
            for body in bodies:
                ref = body.get("schema", {}).get("$ref", "")
                for field in comps.get(ref.rsplit("/", 1)[-1], {}).get("properties", {}):
                    assert f"{field}</code>" in section, (heading, field)


def keys_of(value: Any, prefix: str = "") -> set[str]:
    """Every key path of the dicts in ``value`` (lists: their first item)."""
    if isinstance(value, dict):
        out = set()
        for k, v in value.items():
            out |= {f"{prefix}{k}"} | keys_of(v, f"{prefix}{k}.")
        return out
    if isinstance(value, list) and value:
        return keys_of(value[0], prefix)
    return set()


def test_http_examples_are_real_answers(site: Path, http_page: str, hook: Any, app: Any) -> None:
    shown = json.loads((site / "reference" / "http-examples.json").read_text(encoding="utf-8"))
    assert [(e["method"], e["operation"]) for e in shown] == [
        (e["method"], hook.operation_of(app, e["method"], e["path"])) for e in shown]
    ran = {(e["method"], e["operation"]) for e in shown}
    # every operation a server answers without a vision model has an example
    schema = app.openapi()
    want = {(m.upper(), p) for p, ops in schema["paths"].items() for m in ops
            if "perceive" not in p and "frames" not in p}
    assert want <= ran, sorted(want - ran)
    now = hook.run_examples()
    assert len(now) == len(shown)
    for old, new in zip(shown, now, strict=True):
        what = f"{old['method']} {old['operation']}"
        assert old["status"] == new["status"] and 200 <= new["status"] < 300, (what, new["status"], new["response"])
        assert old["content_type"] == new["content_type"], what
        if new["response"] is None:
            continue
        assert set(old["response"]) == set(new["response"]), what
        # the answer on the page: its keys are the real answer's (lists cut, nothing renamed)
        cut, _ = hook.shorten(new["response"])
        assert keys_of(cut) <= keys_of(new["response"]), what
        for key in new["response"]:
            assert f'"{key}"' in http_page, (what, key)
