"""``X-Forwarded-For`` from a client is not believed: wrong tokens are counted against the
connection's address, so rotating the header gains a guesser nothing and a throttled address
cannot pass as another; the header is read only from a ``--trusted-proxy`` (docs/security.md)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import httpx
import pytest

from siftom.errors import OptionsError
from siftom.service.access import Access, AccessGuard
from siftom.service.hosts import proxy_options
from siftom.service.local_server import serve_in_thread

TOKEN = "k2Jq9-forwarded-for-token-long-enough"


async def _ok_app(scope: Any, receive: Any, send: Any) -> None:
    await send({"type": "http.response.start", "status": 200, "headers": [(b"content-type", b"text/plain")]})
    await send({"type": "http.response.body", "body": (scope.get("client") or ("",))[0].encode()})


def _guesses(url: str, n: int) -> list[int]:
    with httpx.Client(base_url=url, timeout=10) as c:
        return [c.get("/v1/scenarios", headers={"Authorization": f"Bearer wrong-guess-{i:08d}",
                                                 "X-Forwarded-For": f"198.51.{i // 250}.{i % 250 + 1}"}).status_code
                for i in range(n)]


def test_rotating_forwarded_for_gets_no_fresh_address() -> None:
    with serve_in_thread(AccessGuard(_ok_app, Access(token=TOKEN))) as url:
        codes = _guesses(url, 40)
        assert codes[:10] == [401] * 10 and set(codes[10:]) == {429}, codes
        with httpx.Client(base_url=url, timeout=10) as c:  # the right token under a fresh header: still throttled
            r = c.get("/v1/scenarios", headers={"Authorization": f"Bearer {TOKEN}", "X-Forwarded-For": "192.0.2.99"})
        assert r.status_code == 429
        assert int(r.headers["retry-after"]) >= 1


def test_the_app_sees_the_connection_address_not_the_header() -> None:
    with serve_in_thread(AccessGuard(_ok_app, Access())) as url:
        r = httpx.get(f"{url}/", headers={"X-Forwarded-For": "203.0.113.5"}, timeout=10)
    assert r.text == "127.0.0.1"


def test_a_trusted_proxy_passes_the_client_address_on() -> None:
    with serve_in_thread(AccessGuard(_ok_app, Access()), trusted_proxies=("127.0.0.1",)) as url:
        r = httpx.get(f"{url}/", headers={"X-Forwarded-For": "203.0.113.5"}, timeout=10)
    assert r.text == "203.0.113.5"


def test_proxy_options() -> None:
    assert proxy_options() == (False, None)
    assert proxy_options(("127.0.0.1", "10.0.0.0/8")) == (True, ["127.0.0.1/32", "10.0.0.0/8"])
    with pytest.raises(OptionsError, match="--trusted-proxy 'proxy.example'"):
        proxy_options(("proxy.example",))


def test_serve_believes_no_forwarded_header_by_default(monkeypatch: pytest.MonkeyPatch) -> None:
    import uvicorn

    import siftom.service.app as app_module
    from siftom.cli import main
    from siftom.service.local_server import free_port

    seen: dict[str, Any] = {}
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: seen.update(kw))
    monkeypatch.setattr(app_module, "create_app", lambda *a, **kw: SimpleNamespace(
        state=SimpleNamespace(runtime=SimpleNamespace(close=lambda: None))))
    monkeypatch.delenv("SIFTOM_TOKEN", raising=False)
    assert main(["serve", "--port", str(free_port())]) == 0
    assert seen["proxy_headers"] is False
    seen.clear()
    assert main(["serve", "--port", str(free_port()), "--trusted-proxy", "127.0.0.1"]) == 0
    assert seen["proxy_headers"] is True and seen["forwarded_allow_ips"] == ["127.0.0.1/32"]
