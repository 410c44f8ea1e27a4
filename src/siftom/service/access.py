"""Who may use a siftom server: the Host it is asked by, the page a request comes from, a token
(docs/security.md).

* **Host allow-list** (against DNS rebinding: a web page whose name the attacker points at this
  machine): the ``Host`` header must be a loopback name (``localhost``, ``127.0.0.1``, ``::1``),
  an IP address (an address cannot be rebound), or a configured name (``--allow-host``, the
  bound host); any other is a 400. ``*`` turns the check off (a proxy that checks the names).
* **Origin check**: a state-changing request (POST, PUT, PATCH, DELETE) or a WebSocket whose
  ``Origin`` header is present and is neither this server's own origin (the same host and
  port as the ``Host`` header) nor a configured origin (``--allow-origin``) is a 403: a page
  on another site cannot post to the server or stream into it.

* **Token**: when the server has one (``siftom serve`` makes one whenever it listens beyond
  loopback), every request but ``/healthz``, ``/static/*`` and ``/favicon.ico`` must carry it:
  ``Authorization: Bearer TOKEN`` (robots), a ``?token=TOKEN`` query parameter, or the cookie
  that a page URL with ``?token=`` sets (HttpOnly, SameSite=Strict; the browser is then sent
  to the same URL without the token). The WebSocket accepts the same three. Tokens are
  compared in constant time (:func:`secrets.compare_digest`). The ``token`` query parameter is
  taken out of the request before the app (and the access log) sees it.
* **Wrong guesses are slowed**: a client address that sent :data:`MAX_FAILURES` wrong tokens
  within :data:`FAILURE_WINDOW_S` seconds gets 429 (with ``Retry-After``) for every request
  carrying a token until the oldest of them leaves the window; its tokens are not compared
  meanwhile. At most :data:`MAX_TRACKED` addresses are remembered (the least recent forgotten).
* Without a token, a request gets in (loopback only: ``siftom serve`` refuses to listen
  elsewhere without one).

The names and origins are checked by :mod:`siftom.service.hosts`. :class:`AccessGuard` is the ASGI
middleware; :func:`authenticated` tells a handler whether its
request proved the token (``/healthz`` shows its details only then).
"""

from __future__ import annotations

import hashlib
import json
import math
import secrets
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from http.cookies import SimpleCookie
from typing import Any
from urllib.parse import parse_qsl, urlencode

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from siftom.errors import OptionsError
from siftom.service.hosts import (
    LOOPBACK_NAMES,
    Access,
    check_host_name,
    check_origin,
    is_ip,
    is_loopback,
    normal_origin,
    split_host,
)
from siftom.service.problems import ProblemBody

__all__ = ["CLOSE_UNAUTHORIZED", "LOOPBACK_NAMES", "Access", "AccessGuard", "FailureLog", "authenticated",
           "check_host_name", "check_origin", "cookie_name", "is_ip", "is_loopback", "new_token", "normal_origin",
           "split_host"]

OPEN_PATHS = ("/healthz", "/favicon.ico")
OPEN_PREFIXES = ("/static/",)
CLOSE_UNAUTHORIZED = 4401  # a WebSocket without the token
UNSAFE_METHODS = ("POST", "PUT", "PATCH", "DELETE")
AUTH_KEY = "siftom.authenticated"  # set on every scope by AccessGuard
MAX_FAILURES = 10  # wrong tokens one address may send within FAILURE_WINDOW_S ...
FAILURE_WINDOW_S = 60.0
MAX_TRACKED = 4096  # ... addresses remembered at once


def new_token() -> str:
    """A fresh token: 32 random bytes, URL-safe (43 characters)."""
    return secrets.token_urlsafe(32)


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


class FailureLog:
    """Wrong-token attempts per client address in a sliding window, in bounded memory: at most
    ``max_failures`` times per address, at most ``max_clients`` addresses (the least recently
    failing forgotten first)."""

    def __init__(self, max_failures: int = MAX_FAILURES, window_s: float = FAILURE_WINDOW_S,
                 max_clients: int = MAX_TRACKED, clock: Callable[[], float] = time.monotonic) -> None:
        if max_failures < 1 or window_s <= 0 or max_clients < 1:
            raise OptionsError("the wrong-token budget needs max_failures >= 1, window_s > 0, max_clients >= 1")
        self.max_failures, self.window_s, self.max_clients, self.clock = max_failures, window_s, max_clients, clock
        self._seen: OrderedDict[str, deque[float]] = OrderedDict()

    def _recent(self, client: str, now: float) -> deque[float] | None:
        times = self._seen.get(client)
        if times is None:
            return None
        while times and times[0] <= now - self.window_s:
            times.popleft()
        if not times:
            del self._seen[client]
            return None
        return times

    def retry_after(self, client: str) -> int:
        """Seconds until ``client`` may try a token again; 0: it may now."""
        now = self.clock()
        times = self._recent(client, now)
        if times is None or len(times) < self.max_failures:
            return 0
        return max(1, math.ceil(times[0] + self.window_s - now))

    def failed(self, client: str) -> None:
        """Note a wrong token from ``client``."""
        now = self.clock()
        times = self._recent(client, now)
        if times is None:
            times = self._seen[client] = deque(maxlen=self.max_failures)
        times.append(now)
        self._seen.move_to_end(client)
        while len(self._seen) > self.max_clients:
            self._seen.popitem(last=False)

    def __len__(self) -> int:
        return len(self._seen)


class AccessGuard:
    """ASGI middleware enforcing :class:`Access` on HTTP requests and WebSockets.

    ``max_failures``, ``window_s``, ``max_clients`` and ``clock`` set the wrong-token budget
    (:class:`FailureLog`)."""

    def __init__(self, app: ASGIApp, access: Access, *, max_failures: int = MAX_FAILURES,
                 window_s: float = FAILURE_WINDOW_S, max_clients: int = MAX_TRACKED,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.app, self.access = app, access
        tok = access.token
        self._token = tok.encode() if tok else None
        self._cookie = cookie_name(tok) if tok else ""
        self._failures = FailureLog(max_failures, window_s, max_clients, clock)

    def tracked_clients(self) -> int:
        """How many client addresses the wrong-token log holds now."""
        return len(self._failures)

    def _matches(self, given: str | None) -> bool:
        return (self._token is not None and given is not None
                and secrets.compare_digest(given.encode("utf-8", "replace"), self._token))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = _headers(scope)
        host = headers.get("host")
        if not self.access.host_allowed(host):
            shown = (host or "")[:100]
            name = split_host(shown)[0] or "NAME"
            await self._deny(scope, receive, send, 400, "bad-host",
                             f"this server does not answer to the Host {shown!r} (a guard against DNS rebinding); "
                             f"open it as http://localhost:PORT/ or by IP address, or start it with --allow-host {name}")
            return
        origin = headers.get("origin")
        unsafe = scope["type"] == "websocket" or scope.get("method") in UNSAFE_METHODS
        if unsafe and origin is not None and not self.access.origin_allowed(origin, host, scope.get("scheme", "http")):
            shown = origin[:100]
            await self._deny(scope, receive, send, 403, "bad-origin",
                             f"a request from the page {shown!r} is refused: pages of other sites cannot change this "
                             "server's data or stream into it; open the page from this server, or start it with "
                             f"--allow-origin {shown}")
            return
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
        given = bearer is not None or cookie is not None or bool(from_query)
        client = (scope.get("client") or ("",))[0] or ""
        if given:
            wait = self._failures.retry_after(client)
            if wait:  # too many wrong guesses from this address: not even compared
                await self._throttle(scope, receive, send, wait)
                return
        query_ok = any(self._matches(v) for v in from_query)
        ok = self._matches(bearer) or query_ok or self._matches(cookie)
        scope[AUTH_KEY] = ok
        if given and not ok:
            self._failures.failed(client)
        path = scope.get("path", "")
        if not ok and not (path in OPEN_PATHS or path.startswith(OPEN_PREFIXES)):
            await self._refuse(scope, receive, send, given)
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

    async def _throttle(self, scope: Scope, receive: Receive, send: Send, wait: int) -> None:
        log = self._failures
        detail = (f"too many wrong tokens from this address (at most {log.max_failures} in "
                  f"{log.window_s:g} s); wait {wait} s (Retry-After), then send the right token: the one "
                  "siftom serve printed or was given with --token, --token-file or SIFTOM_TOKEN")
        await self._deny(scope, receive, send, 429, "too-many-wrong-tokens", detail,
                         [(b"retry-after", str(wait).encode())])

    @staticmethod
    async def _deny(scope: Scope, receive: Receive, send: Send, status: int, slug: str, detail: str,
                    extra: list[tuple[bytes, bytes]] | None = None) -> None:
        """A problem response; a WebSocket is refused before its handshake completes."""
        body = json.dumps(ProblemBody(status, slug, detail).to_json()).encode()
        headers = [(b"content-type", b"application/problem+json"), (b"content-length", str(len(body)).encode()),
                   *(extra or [])]
        if scope["type"] == "websocket":
            msg = await receive()
            if msg["type"] != "websocket.connect":
                return
            if "websocket.http.response" in scope.get("extensions", {}):
                await send({"type": "websocket.http.response.start", "status": status, "headers": headers})
                await send({"type": "websocket.http.response.body", "body": body})
            else:
                await send({"type": "websocket.close", "code": 4000 + status, "reason": detail[:123]})
            return
        await send({"type": "http.response.start", "status": status, "headers": headers})
        await send({"type": "http.response.body", "body": body})

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
        body = json.dumps(ProblemBody(401, "unauthorized", f"{what}: {fix}").to_json()).encode()
        await send({"type": "http.response.start", "status": 401,
                    "headers": [(b"content-type", b"application/problem+json"),
                                (b"content-length", str(len(body)).encode()),
                                (b"www-authenticate", b'Bearer realm="siftom"')]})
        await send({"type": "http.response.body", "body": body})
