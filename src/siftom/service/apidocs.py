"""Interactive API docs at ``/docs`` (Swagger UI), served from local files.

A robot is often offline, so the page loads nothing from a CDN: the Swagger UI bundle is the one
shipped by the ``fastapi-offline`` package (part of the ``serve`` extra), mounted at
``/docs-assets``. The page carries its own Content-Security-Policy that lets it load from this
server only, so a stray outside URL would be blocked by the browser rather than fetched.
(No ReDoc page: its bundle loads its logo from the vendor's CDN.)
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from siftom.service.problems import ProblemError

ASSETS = "/docs-assets"
# The page's own script is inline (FastAPI's template) and Swagger UI styles inline: everything
# else comes from this server.
DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data:; font-src 'self' data:; connect-src 'self'; "
            "object-src 'none'; base-uri 'none'; frame-ancestors 'none'")


def assets_dir() -> Path | None:
    """The folder with ``swagger-ui-bundle.js`` and ``swagger-ui.css``, or None when
    ``fastapi-offline`` is not installed."""
    try:
        import fastapi_offline
    except ModuleNotFoundError:
        return None
    folder = Path(fastapi_offline.__file__).parent / "static"
    return folder if (folder / "swagger-ui-bundle.js").is_file() else None


def install_docs(app: FastAPI) -> None:
    """Add ``GET /docs`` and the assets it loads to ``app``."""
    folder = assets_dir()
    if folder is not None:
        app.mount(ASSETS, StaticFiles(directory=folder), name="docs-assets")

    def need_assets() -> None:
        if folder is None:
            raise ProblemError(501, "missing-extra", "the API docs need fastapi-offline; install it with: "
                               "pip install \"siftom[serve]\" (the schema is at /openapi.json)")

    @app.get("/docs", include_in_schema=False, response_class=HTMLResponse)
    async def swagger_ui(request: Request) -> HTMLResponse:
        need_assets()
        root = request.scope.get("root_path", "")
        page = get_swagger_ui_html(
            openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} {app.version}: HTTP API",
            swagger_js_url=f"{root}{ASSETS}/swagger-ui-bundle.js",
            swagger_css_url=f"{root}{ASSETS}/swagger-ui.css",
            swagger_favicon_url=f"{root}/favicon.ico",
            # no badge from the public validator: the page asks nothing of other hosts
            swagger_ui_parameters={"validatorUrl": None, "tryItOutEnabled": True})
        page.headers["content-security-policy"] = DOCS_CSP
        return page
