"""Who may use a siftom server: a token, as Jupyter does (docs/security.md).

* **Token**: when the server has one (``siftom serve`` makes one whenever it listens beyond
  loopback), every request but ``/healthz``, ``/static/*`` and ``/favicon.ico`` must carry it:
  ``Authorization: Bearer TOKEN`` (robots), a ``?token=TOKEN`` query parameter, or the cookie
  that a page URL with ``?token=`` sets (HttpOnly, SameSite=Strict; the browser is then sent
  to the same URL without the token). The WebSocket accepts the same three. Tokens are
  compared in constant time (:func:`secrets.compare_digest`). The ``token`` query parameter is
  taken out of the request before the app (and the access log) sees it.
* Without a token, a request gets in (loopback only: ``siftom serve`` refuses to listen
  elsewhere without one).

:class:`AccessGuard` is the ASGI middleware; :func:`authenticated` tells a handler whether its
request proved the token (``/healthz`` shows its details only then).
"""

from __future__ import annotations

import hashlib
import ipaddress
import json
import secrets
from dataclasses import dataclass
from http.cookies import SimpleCookie
from typing import Any
from urllib.parse import parse_qsl, urlencode

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from siftom.options import check_token
from siftom.service.problems import problem

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
OPEN_PATHS = ("/healthz", "/favicon.ico")
OPEN_PREFIXES = ("/static/",)
CLOSE_UNAUTHORIZED = 4401  # a WebSocket without the token
AUTH_KEY = "siftom.authenticated"  # set on every scope by AccessGuard


def new_token() -> str:
    """A fresh token: 32 random bytes, URL-safe (43 characters)."""
    return secrets.token_urlsafe(32)


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    host = host.strip().strip("[]").lower()
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def cookie_name(token: str) -> str:
    """The cookie holding ``token``: named after a digest of it, so that servers on other ports
    of the same machine (cookies ignore ports) keep their own."""
    return "siftom-token-" + hashlib.sha256(token.encode()).hexdigest()[:8]


def authenticated(scope_or_request: Any) -> bool:
    """Whether the request proved the token (always True on a server without one)."""
    scope = getattr(scope_or_request, "scope", scope_or_request)
    return bool(scope.get(AUTH_KEY, True))


def _headers(scope: Scope) -> dict[str, str]:
    out: dict[str, str] = {}
    for k, v in scope.get("headers", ()):
        name = k.decode("latin-1").lower()
        value = v.decode("latin-1")
        out[name] = f"{out[name]}; {value}" if name == "cookie" and name in out else value
    return out


@dataclass(frozen=True)
class Access:
    """What a server checks (see module doc). ``token`` None: no token asked for."""

    token: str | None = None

    def __post_init__(self) -> None:
        if self.token is not None:
            object.__setattr__(self, "token", check_token(self.token))


class AccessGuard:
    """ASGI middleware enforcing :class:`Access` on HTTP requests and WebSockets."""

    def __init__(self, app: ASGIApp, access: Access) -> None:
        self.app, self.access = app, access
        tok = access.token
        self._token = tok.encode() if tok else None
        self._cookie = cookie_name(tok) if tok else ""

    def _matches(self, given: str | None) -> bool:
        return (self._token is not None and given is not None
                and secrets.compare_digest(given.encode("utf-8", "replace"), self._token))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = _headers(scope)
        # take ?token= out of the query: the app never sees it, nor does the access log
        pairs = parse_qsl(scope.get("query_string", b"").decode("latin-1"), keep_blank_values=True)
        from_query = [v for k, v in pairs if k == "token"]
        if from_query:
            scope["query_string"] = urlencode([(k, v) for k, v in pairs if k != "token"]).encode("latin-1")
        if self._token is None:
            scope[AUTH_KEY] = True
            await self.app(scope, receive, send)
            return
        bearer = None
        auth = headers.get("authorization", "")
        if auth[:7].lower() == "bearer ":
            bearer = auth[7:].strip()
        jar: SimpleCookie = SimpleCookie()
        try:
            jar.load(headers.get("cookie", ""))
        except Exception:  # a malformed Cookie header counts as none
            jar = SimpleCookie()
        cookie = jar[self._cookie].value if self._cookie in jar else None
        query_ok = any(self._matches(v) for v in from_query)
        ok = self._matches(bearer) or query_ok or self._matches(cookie)
        scope[AUTH_KEY] = ok
        path = scope.get("path", "")
        if not ok and not (path in OPEN_PATHS or path.startswith(OPEN_PREFIXES)):
            await self._refuse(scope, receive, send, bearer is not None or cookie is not None or bool(from_query))
            return
        if scope["type"] == "http" and query_ok:
            await self._set_cookie(scope, receive, send, headers)
            return
        await self.app(scope, receive, send)

    def _cookie_header(self, scope: Scope) -> bytes:
        secure = "; Secure" if scope.get("scheme") == "https" else ""
        return (f"{self._cookie}={self.access.token}; Path=/; HttpOnly; SameSite=Strict{secure}").encode()

    async def _set_cookie(self, scope: Scope, receive: Receive, send: Send, headers: dict[str, str]) -> None:
        """A page opened with ?token=: set the cookie and load the page again without the token
        in the address bar; any other request is answered as usual, with the cookie set."""
        cookie = (b"set-cookie", self._cookie_header(scope))
        if scope.get("method") in ("GET", "HEAD") and "text/html" in headers.get("accept", ""):
            qs = scope.get("query_string", b"").decode("latin-1")
            location = scope.get("root_path", "") + scope.get("path", "/") + (f"?{qs}" if qs else "")
            await send({"type": "http.response.start", "status": 303,
                        "headers": [(b"location", location.encode("latin-1")), cookie,
                                    (b"cache-control", b"no-store"), (b"content-length", b"0")]})
            await send({"type": "http.response.body", "body": b""})
            return

        async def with_cookie(msg: Message) -> None:
            if msg["type"] == "http.response.start":
                msg = {**msg, "headers": [*msg.get("headers", []), cookie]}
            await send(msg)

        await self.app(scope, receive, with_cookie)

    @staticmethod
    async def _refuse(scope: Scope, receive: Receive, send: Send, wrong: bool) -> None:
        what = "the token is wrong" if wrong else "this server needs its token"
        fix = ("open the URL siftom serve printed (http://HOST:PORT/?token=...), or send the header "
               "Authorization: Bearer TOKEN; the token is the one given with --token, --token-file or "
               "SIFTOM_TOKEN")
        if scope["type"] == "websocket":
            msg = await receive()
            if msg["type"] != "websocket.connect":
                return
            await send({"type": "websocket.accept"})
            reason = f"{what}: send Authorization: Bearer TOKEN, or ?token=TOKEN"
            await send({"type": "websocket.close", "code": CLOSE_UNAUTHORIZED, "reason": reason[:123]})
            return
        body = json.dumps(problem(401, "unauthorized", f"{what}: {fix}")).encode()
        await send({"type": "http.response.start", "status": 401,
                    "headers": [(b"content-type", b"application/problem+json"),
                                (b"content-length", str(len(body)).encode()),
                                (b"www-authenticate", b'Bearer realm="siftom"')]})
        await send({"type": "http.response.body", "body": body})
