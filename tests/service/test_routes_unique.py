"""Every door of the service is declared once: no (path, method) is routed twice, and the
OpenAPI document lists each of them exactly once."""

from __future__ import annotations

from collections import Counter
from typing import Any

import pytest

pytest.importorskip("fastapi", reason="needs the serve extra: pip install 'siftom[serve]'")

from fastapi.routing import APIRoute, APIWebSocketRoute  # noqa: E402


def _routes(app: Any) -> list[Any]:
    """The app's routes, those of included routers flattened (FastAPI may keep them nested)."""
    try:
        from fastapi.routing import iter_route_contexts
    except ImportError:  # an older FastAPI copies the routers' routes into the app
        return list(app.routes)
    return [ctx.original_route for ctx in iter_route_contexts(app.routes)]


def _doors(app: Any) -> Counter[tuple[str, str]]:
    doors: Counter[tuple[str, str]] = Counter()
    for route in _routes(app):
        if isinstance(route, APIRoute):
            doors.update((route.path_format, m) for m in route.methods)
        elif isinstance(route, APIWebSocketRoute):
            doors[(route.path_format, "WEBSOCKET")] += 1
    return doors


def test_no_path_and_method_is_routed_twice(app):
    doors = _doors(app)
    assert doors, "no routes found"
    assert [door for door, n in doors.items() if n > 1] == []
    assert doors[("/v1/sessions/{session_id}/frames", "POST")] == 1
    assert doors[("/v1/sessions/{session_id}/listen", "WEBSOCKET")] == 1


def test_each_documented_operation_appears_once(client):
    schema = client.get("/openapi.json").json()
    listed = Counter((path, method.upper()) for path, ops in schema["paths"].items() for method in ops)
    assert [op for op, n in listed.items() if n > 1] == []
    assert listed[("/v1/sessions/{session_id}/frames", "POST")] == 1
    documented = {door for door in _doors(client.app) if door[1] != "WEBSOCKET"}
    in_schema = {(r.path_format, m) for r in _routes(client.app) if isinstance(r, APIRoute) and r.include_in_schema
                 for m in r.methods}
    assert set(listed) == in_schema and in_schema <= documented
    ids = [op["operationId"] for ops in schema["paths"].values() for op in ops.values()]
    assert len(ids) == len(set(ids))
