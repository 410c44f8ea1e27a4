"""``Idempotency-Key``: a retried mutating session request gets its first answer and changes nothing.

A robot whose request timed out cannot know whether it was applied. Sending the same
``Idempotency-Key`` header again (any string of 1-200 visible ASCII characters, unique per
request within a session, e.g. a UUID) returns the answer the first request got, with the
header ``Idempotent-Replayed: true``, and changes nothing. The first answer is written to the
session store in the same transaction as the change it answers, so this holds across a
restart. The same key sent with a different request is a 422 (a client bug, not a retry).
Creating a session (``POST /v1/sessions``, ``/v1/sessions/from-scenario``) takes a key too,
unique server-wide (there is no session yet to scope it), and so does ``POST .../rating``.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

from siftom.service.problems import ProblemError

HEADER = "Idempotency-Key"
REPLAYED = "Idempotent-Replayed"
MAX_KEY = 200


@dataclass(frozen=True)
class Idem:
    """A request's idempotency key and the fingerprint of what it asks (route and body)."""

    key: str
    request: str


Part = bytes | str | BaseModel | Mapping[str, str]


def fingerprint(route: str, *parts: Part) -> str:
    """A digest of the route and the request's content (a request model's fields, or form
    fields, in a canonical JSON form)."""
    h = hashlib.sha256(route.encode())
    for p in parts:
        if isinstance(p, BaseModel):
            p = p.model_dump()
        if isinstance(p, Mapping):
            p = json.dumps(dict(p), sort_keys=True, separators=(",", ":"))
        h.update(b"\0" + (p.encode() if isinstance(p, str) else p))
    return f"{route} {h.hexdigest()}"


def idem_of(headers: Any, route: str, *parts: Part) -> Idem | None:
    """The request's :class:`Idem`, None without the header; 422 for a malformed key."""
    key = headers.get(HEADER)
    if key is None:
        return None
    if not 1 <= len(key) <= MAX_KEY or not all(33 <= ord(ch) <= 126 for ch in key):
        raise ProblemError(422, "invalid-idempotency-key",
                           f"the {HEADER} header must be 1-{MAX_KEY} visible ASCII characters without spaces "
                           "(e.g. a UUID), one per request")
    return Idem(key, fingerprint(route, *parts))


def check_same(idem: Idem, stored_request: str) -> None:
    """422 when a key comes back with a different request than the one it first answered."""
    if stored_request != idem.request:
        raise ProblemError(422, "idempotency-key-reused",
                           f"this {HEADER} ({idem.key!r}) already answered a different request in this session; "
                           "send a new key with each new request and the same key only to retry one")
