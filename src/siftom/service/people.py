"""What the participant pages share: a small app with the service's error handling and
content policy, and the scene frames (the map after each observed action) as cached PNGs.

:mod:`siftom.service.collect_app` (recording instructions) and
:mod:`siftom.service.annotate_app` (the human baseline) build on it. The pages load nothing
from elsewhere (the same Content-Security-Policy as the demo page) and the server listens on
loopback unless told otherwise, so recordings and answers stay on the machine.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, TypeVar

import anyio
import anyio.to_thread
from fastapi import FastAPI
from fastapi.encoders import jsonable_encoder
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

from siftom.service.access import Access, AccessGuard
from siftom.service.problems import (
    BodyLimitMiddleware,
    ProblemError,
    SecurityHeadersMiddleware,
    install_handlers,
)

STATIC = Path(__file__).parent / "static"
MAX_BODY = 8 * 2**20  # a 30 s recording as 16-bit WAV at 48 kHz stereo is under 6 MiB
R = TypeVar("R")
RunCpu = Callable[..., Awaitable[Any]]


def page_app(title: str, page: str, max_body: int = MAX_BODY, access: Access | None = None
             ) -> tuple[FastAPI, RunCpu]:
    """An app serving ``static/PAGE`` at ``/`` and the static files; returns it and a ``run_cpu``.

    ``access``: the Host, Origin and token checks (:mod:`siftom.service.access`; default: Host
    and Origin only)."""
    app = FastAPI(title=title, docs_url=None, redoc_url=None, openapi_url=None)
    install_handlers(app)
    app.add_middleware(BodyLimitMiddleware, max_bytes=max_body)
    app.add_middleware(AccessGuard, access=access or Access())
    app.add_middleware(SecurityHeadersMiddleware)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    limiter = anyio.CapacityLimiter(2)

    @app.get("/", include_in_schema=False)
    async def index() -> FileResponse:
        return FileResponse(STATIC / page, media_type="text/html")

    @app.get("/favicon.ico", include_in_schema=False)
    async def favicon() -> FileResponse:
        return FileResponse(STATIC / "favicon.svg", media_type="image/svg+xml")

    async def run_cpu(fn: Callable[..., R], *args: Any) -> R:
        return await anyio.to_thread.run_sync(functools.partial(fn, *args), limiter=limiter)

    return app, run_cpu


class Frames:
    """The scene after each observed action, rendered once to ``folder`` (siftom.world.render)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.folder.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()

    def png(self, scenario: Any, step: int) -> Path:
        """The frame after ``step`` actions (0 = the start); a 404 problem when out of range."""
        n = len(scenario.actions)
        if not 0 <= step <= n:
            raise ProblemError(404, "no-frame", f"step {step} is outside 0..{n} for this scenario")
        from siftom.world.render import render_scenario

        acts = "\n".join(scenario.world.format_action(a) for a in scenario.actions)
        key = hashlib.sha256(f"{scenario.id}\n{acts}\n{step}".encode()).hexdigest()[:24]
        path = self.folder / f"{key}.png"
        with self._lock:
            if not path.is_file():
                title = "before the first action" if step == 0 else f"after action {step} of {n}"
                tmp = self.folder / f".{key}.{threading.get_ident()}.png"
                render_scenario(scenario, tmp, step=step, title=title)
                _crop(tmp)
                tmp.replace(path)
        return path


def _crop(path: Path, margin: int = 12) -> None:
    """Cut the white border of a rendered map so that its labels are shown larger."""
    from PIL import Image, ImageChops

    with Image.open(path) as im:
        rgb = im.convert("RGB")
    box = ImageChops.difference(rgb, Image.new("RGB", rgb.size, (255, 255, 255))).getbbox()
    if box:
        x0, y0, x1, y1 = box
        rgb.crop((max(0, x0 - margin), max(0, y0 - margin), min(rgb.width, x1 + margin),
                  min(rgb.height, y1 + margin))).save(path)


def png_response(path: Path) -> FileResponse:
    return FileResponse(path, media_type="image/png", headers={"Cache-Control": "max-age=3600"})


def json_response(body: Any, status_code: int = 200) -> JSONResponse:
    """``body`` (the page API's answer) as JSON, encoded as FastAPI encodes a returned value."""
    return JSONResponse(jsonable_encoder(body), status_code=status_code)
