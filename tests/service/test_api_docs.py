"""Interactive API docs at /docs: served from this server's own files, no CDN."""

from __future__ import annotations

import re

URL_ATTR = re.compile(r"""(?:src|href)\s*=\s*["']([^"']+)["']|\burl:\s*'([^']+)'""")


def local_urls(html: str) -> list[str]:
    found = [next(g for g in m.groups() if g) for m in URL_ATTR.finditer(html)]
    assert found, "the page names no asset at all"
    return found


def test_docs_page_loads_only_local_urls(client):
    r = client.get("/docs")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("text/html")
    html = r.text
    assert "http://" not in html and "https://" not in html, "the page names another host"
    for url in local_urls(html):
        assert url.startswith("/") and not url.startswith("//"), url
        got = client.get(url)
        assert got.status_code == 200, (url, got.status_code)
        assert len(got.content) > 100, url
    # the browser may load from this server only (a stray CDN URL would be blocked, not fetched)
    csp = r.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "connect-src 'self'" in csp
    assert "http" not in csp


def test_swagger_ui_reads_the_schema_and_its_bundle(client):
    html = client.get("/docs").text
    urls = local_urls(html)
    assert "/openapi.json" in urls
    js = next(u for u in urls if u.endswith("swagger-ui-bundle.js"))
    assert "SwaggerUIBundle" in client.get(js).text
    assert '"validatorUrl": null' in html  # no badge fetched from the public validator
    assert client.get("/openapi.json").json()["paths"]["/v1/infer"]


def test_docs_page_is_not_in_the_schema(client):
    paths = client.get("/openapi.json").json()["paths"]
    assert not any(p.startswith("/docs") for p in paths)


def test_without_the_assets_docs_says_what_to_install(tmp_path, monkeypatch):
    from siftom.service import apidocs
    from siftom.service.app import create_app
    from support.client import local_client

    monkeypatch.setattr(apidocs, "assets_dir", lambda: None)
    with local_client(create_app(tmp_path)) as c:
        r = c.get("/docs")
    assert r.status_code == 501
    assert 'pip install "siftom[serve]"' in r.json()["detail"]
