"""Errors as RFC 9457 problem details, and the ASGI guards that produce some of them.

Every error response is ``application/problem+json`` with ``type``, ``title``, ``status`` and
``detail``. Client mistakes are 4xx; a 5xx means a bug or an overloaded server.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sqlite3
from dataclasses import dataclass
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from siftom.errors import BackendUnavailableError, NotYoursError, SiftomError, UnknownNameError
from siftom.service.diskfull import DiskFullError, damaged_fix, is_damaged, is_disk_full
from siftom.world.io import WorldTooLargeError

log = logging.getLogger("siftom.service")
PROBLEM_JSON = "application/problem+json"
DISK_FULL = ("the server's disk is full, so nothing was written; DELETE the sessions you no longer need "
             "(DELETE /v1/sessions/{id} works on a full disk) and try again, or free space in the server's data "
             "folder")
DISK_FULL_DELETE = ("the server's disk is full, so even this DELETE could not be written (the room kept for "
                    "deletes is used up, or the disk was already short of it when the server started); free space "
                    "in the server's data folder, then send the DELETE again")


STORE_DAMAGED = ("the server's session store is damaged (SQLite: database disk image is malformed), so this request "
                 "could not be carried out; nothing in the request is wrong. Its operator must stop the server, "
                 "move sessions.sqlite3 (and its -wal and -shm files) aside in the server's data folder and start "
                 "it again (the server's log names the file)")


def disk_full_detail(method: str) -> str:
    """What a 507 says: a DELETE is the way out of a full disk unless it is what failed."""
    return DISK_FULL_DELETE if method == "DELETE" else DISK_FULL


@dataclass(frozen=True)
class FieldError:
    """One invalid field of a request: where (``loc``, dotted) and what is wrong (``msg``)."""

    loc: str
    msg: str


class ProblemError(Exception):
    """Raise inside a handler to answer with a problem document."""

    def __init__(self, status: int, slug: str, detail: str, errors: list[FieldError] | None = None,
                 headers: dict[str, str] | None = None) -> None:
        super().__init__(detail)
        self.status, self.slug, self.detail, self.errors, self.headers = status, slug, detail, errors, headers


@dataclass(frozen=True)
class ProblemBody:
    """A problem-details document: ``type`` (``urn:siftom:problem:SLUG``), the status's ``title``,
    ``status``, ``detail`` and, for a request with invalid fields, ``errors``."""

    status: int
    slug: str
    detail: str
    errors: tuple[FieldError, ...] = ()

    def to_json(self) -> dict[str, Any]:
        body: dict[str, Any] = {"type": f"urn:siftom:problem:{self.slug}", "title": HTTPStatus(self.status).phrase,
                                "status": self.status, "detail": self.detail}
        if self.errors:
            body["errors"] = [{"loc": e.loc, "msg": e.msg} for e in self.errors]
        return body


def problem_response(status: int, slug: str, detail: str, errors: list[FieldError] | None = None,
                     headers: dict[str, str] | None = None) -> JSONResponse:
    return JSONResponse(ProblemBody(status, slug, detail, tuple(errors or ())).to_json(), status_code=status,
                        media_type=PROBLEM_JSON, headers=headers)


def validation_errors(exc: ValidationError | RequestValidationError) -> list[FieldError]:
    """Pydantic's errors, each as where and what (no echo of the input: it may be large)."""
    out = []
    for e in exc.errors():
        loc = ".".join(str(p) for p in e.get("loc", ()) if p not in ("body",))
        out.append(FieldError(loc, str(e.get("msg", "invalid"))))
    return out


def _summary(errors: list[FieldError]) -> str:
    first = errors[0] if errors else FieldError("", "invalid request")
    where = f"{first.loc}: " if first.loc else ""
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return f"{where}{first.msg}{more}"


def install_handlers(app: FastAPI) -> None:
    """Map every exception to a problem document."""

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error on %s %s", request.method, request.url.path, exc_info=exc)
        return problem_response(500, "internal", "an internal error occurred; the server log has the details")

    @app.exception_handler(ProblemError)
    async def _problem(_: Request, exc: ProblemError) -> JSONResponse:
        return problem_response(exc.status, exc.slug, exc.detail, exc.errors, exc.headers)

    @app.exception_handler(RequestValidationError)
    async def _request_validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        errs = validation_errors(exc)
        return problem_response(422, "validation", _summary(errs), errs)

    @app.exception_handler(ValidationError)
    async def _validation(_: Request, exc: ValidationError) -> JSONResponse:
        errs = validation_errors(exc)
        return problem_response(422, "validation", _summary(errs), errs)

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else HTTPStatus(exc.status_code).phrase
        if exc.status_code == 404 and detail == "Not Found":
            detail = "no such endpoint; see /openapi.json or /docs"
        return problem_response(exc.status_code, "http", detail, headers=getattr(exc, "headers", None))

    @app.exception_handler(UnknownNameError)
    async def _unknown(_: Request, exc: UnknownNameError) -> JSONResponse:
        return problem_response(404, "unknown-name", str(exc))

    @app.exception_handler(NotYoursError)
    async def _not_yours(_: Request, exc: NotYoursError) -> JSONResponse:
        return problem_response(403, "not-yours", str(exc))

    @app.exception_handler(BackendUnavailableError)
    async def _backend(_: Request, exc: BackendUnavailableError) -> JSONResponse:
        return problem_response(501, "backend-unavailable", str(exc))

    @app.exception_handler(DiskFullError)
    async def _disk_full(request: Request, exc: Exception) -> JSONResponse:
        if request.scope["type"] != "http":  # a WebSocket: as if no handler were here
            raise exc
        return problem_response(507, "insufficient-storage", disk_full_detail(request.method))

    for kind in (OSError, sqlite3.Error):  # a write elsewhere than the session store (e.g. the map cache)
        @app.exception_handler(kind)
        async def _write_failed(request: Request, exc: Exception) -> JSONResponse:
            if request.scope["type"] != "http":  # a WebSocket: as if no handler were here
                raise exc
            if is_disk_full(exc):
                return problem_response(507, "insufficient-storage", disk_full_detail(request.method))
            if is_damaged(exc):  # the server's file, not the request: say so, and what its operator does
                store = getattr(getattr(request.app.state, "sessions", None), "store", None)
                where = getattr(store, "path", "sessions.sqlite3")
                log.error("the session store %s is damaged (%s): stop the server and %s", where, exc, damaged_fix(where))
                return problem_response(500, "store-damaged", STORE_DAMAGED)
            return await _bug(request, exc)

    @app.exception_handler(WorldTooLargeError)
    async def _world_limit(_: Request, exc: WorldTooLargeError) -> JSONResponse:
        return problem_response(422, "world-over-limit", str(exc))

    @app.exception_handler(SiftomError)
    async def _siftom(_: Request, exc: SiftomError) -> JSONResponse:
        return problem_response(422, "invalid-observation", str(exc))


    app.add_middleware(_KeepConnectionMiddleware)


STOPPING = ("the server is stopping and its grace for requests in flight ran out before this one was answered; "
            "it may or may not have been carried out: send it again once the server is back (with the same "
            "Idempotency-Key, a change is made once)")


class _KeepConnectionMiddleware:
    """Answer an unhandled exception with a 500 problem here, so it does not reach the server,
    which would drop the keep-alive connection (the client's next request would be reset). A
    request still running when the server's stop grace ends (uvicorn cancels it) is a 503
    problem, not the server's plain-text 500."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        out = _TrackedSend(send)
        try:
            await self.app(scope, receive, out)
        except _TooLarge:
            raise
        except asyncio.CancelledError:
            if out.started:
                raise
            log.warning("stopping: %s %s cancelled before its answer", scope.get("method"), scope.get("path"))
            await send_problem(send, 503, "stopping", STOPPING, close=True, headers=((b"retry-after", b"5"),))
        except Exception:
            if out.started:
                raise
            log.exception("unhandled error on %s %s", scope.get("method"), scope.get("path"))
            await send_problem(send, 500, "internal", "an internal error occurred; the server log has the details")


class _TrackedSend:
    """``send`` that remembers whether the response has started (after that, no problem can be sent)."""

    def __init__(self, send: Send) -> None:
        self.send, self.started = send, False

    async def __call__(self, msg: Message) -> None:
        if msg["type"] == "http.response.start":
            self.started = True
        await self.send(msg)


async def send_problem(send: Send, status: int, slug: str, detail: str, close: bool = False,
                       headers: tuple[tuple[bytes, bytes], ...] = ()) -> None:
    """Send a whole problem-details response on a raw ASGI ``send``."""
    body = json.dumps(ProblemBody(status, slug, detail).to_json()).encode()
    headers = ((b"content-type", PROBLEM_JSON.encode()), (b"content-length", str(len(body)).encode()), *headers)
    if close:
        headers = (*headers, (b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": list(headers)})
    await send({"type": "http.response.body", "body": body})


class _TooLarge(Exception):
    pass


class BodyLimitMiddleware:
    """Refuse request bodies over ``max_bytes`` (413) by Content-Length and while streaming."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app, self.max_bytes = app, max_bytes

    @staticmethod
    async def _refuse(send: Send, status: int, slug: str, detail: str) -> None:
        await send_problem(send, status, slug, detail, close=True)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.max_bytes
        too_big = f"the request body is larger than the {limit} bytes allowed; send a shorter recording or text"
        for name, value in scope.get("headers", ()):
            if name == b"content-length":
                try:
                    n = int(value)
                except ValueError:
                    await self._refuse(send, 400, "bad-request", "the Content-Length header is not a number")
                    return
                if n > limit:
                    await self._refuse(send, 413, "too-large", too_big)
                    return
        seen = 0

        async def limited_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > limit:
                    raise _TooLarge
            return msg

        out = _TrackedSend(send)
        try:
            await self.app(scope, limited_receive, out)
        except _TooLarge:
            if not out.started:
                await self._refuse(send, 413, "too-large", too_big)


# The page loads nothing from elsewhere; the policy makes sure of it.
CSP = ("default-src 'self'; img-src 'self' data: blob:; media-src 'self' blob:; style-src 'self'; "
       "script-src 'self'; connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'")


class SecurityHeadersMiddleware:
    """Add nosniff everywhere and a strict Content-Security-Policy to the web page."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def add_headers(msg: Message) -> None:
            if msg["type"] == "http.response.start":
                headers = list(msg.get("headers", []))
                headers.append((b"x-content-type-options", b"nosniff"))
                if not scope["path"].startswith(("/docs", "/redoc")):
                    headers.append((b"content-security-policy", CSP.encode()))
                msg = {**msg, "headers": headers}
            await send(msg)

        await self.app(scope, receive, add_headers)


async def read_audio_form(request: Request, *, max_fields: int, max_part_size: int) -> tuple[dict[str, str], bytes]:
    """A multipart upload with one file field ``audio`` and text fields (each given once):
    returns (fields, audio bytes); a malformed form is a 400, a missing or repeated field a 422."""
    from starlette.datastructures import UploadFile

    try:
        form = await request.form(max_files=1, max_fields=max_fields, max_part_size=max_part_size)
    except _TooLarge:  # a chunked body over the limit: BodyLimitMiddleware answers 413
        raise
    except Exception as exc:  # malformed multipart, too many parts
        detail = getattr(exc, "detail", None) or str(exc) or "malformed multipart body"
        if "maximum size" in str(detail):
            raise ProblemError(413, "too-large", f"a part of the form is larger than the {max_part_size} bytes "
                               "allowed; send a shorter recording") from None
        raise ProblemError(400, "bad-multipart", f"cannot read the form: {detail}") from None
    try:
        audio = form.get("audio")
        if not isinstance(audio, UploadFile):
            raise ProblemError(422, "validation", "audio: a file field named 'audio' is required",
                               [FieldError("audio", "a file is required")])
        fields: dict[str, str] = {}
        for k, v in form.multi_items():
            if k == "audio":
                continue
            if k in fields or not isinstance(v, str):
                raise ProblemError(422, "validation", f"{k}: give the field once, as text",
                                   [FieldError(k, "repeated or not text")])
            fields[k] = v
        return fields, await audio.read()
    finally:
        await form.close()
