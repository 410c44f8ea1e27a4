"""MkDocs hook: write the HTTP API reference from the service's OpenAPI schema at build time.

``siftom.service.app.create_app`` builds the FastAPI app; its schema is written next to the page
(``reference/openapi.json``) and summarised in ``reference/http.md`` (one row per endpoint).
"""

from __future__ import annotations

import json
import tempfile
from typing import Any

PAGE = "reference/http.md"
SCHEMA = "reference/openapi.json"
MARK = "<!-- endpoints -->"


def openapi_schema() -> dict[str, Any]:
    """The service's OpenAPI schema (needs the ``serve`` extra)."""
    from siftom.service.app import create_app

    with tempfile.TemporaryDirectory() as d:
        return create_app(d).openapi()


def endpoint_table(schema: dict[str, Any]) -> str:
    """A Markdown table: method, path, summary, one row per operation, in the schema's order."""
    rows = ["| method | path | what it does |", "|---|---|---|"]
    for path, ops in schema.get("paths", {}).items():
        for method, op in ops.items():
            if method.startswith("x-") or not isinstance(op, dict):
                continue
            summary = (op.get("description") or op.get("summary") or "").strip().splitlines()
            text = (summary[0] if summary else "").replace("|", "\\|")
            rows.append(f"| `{method.upper()}` | `{path}` | {text} |")
    return "\n".join(rows)


_SCHEMA: dict[str, Any] | None = None


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill the endpoint table into the HTTP page."""
    global _SCHEMA
    if page.file.src_uri != PAGE or MARK not in markdown:
        return markdown
    if _SCHEMA is None:
        _SCHEMA = openapi_schema()
    return markdown.replace(MARK, endpoint_table(_SCHEMA))


def on_files(files: Any, config: Any) -> Any:
    """Ship the full schema with the site (``reference/openapi.json``), generated, never committed."""
    global _SCHEMA
    from mkdocs.structure.files import File

    if _SCHEMA is None:
        _SCHEMA = openapi_schema()
    files.append(File.generated(config, SCHEMA, content=json.dumps(_SCHEMA, indent=2) + "\n"))
    return files
