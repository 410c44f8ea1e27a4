"""MkDocs hook: write the HTTP API reference from the service itself at build time.

``siftom.service.app.create_app`` builds the FastAPI app. Its schema is written next to the page
(``reference/openapi.json``), and ``reference/http.md`` gets, in place of its markers:

* ``<!-- endpoints -->``: one row per endpoint of the schema, then the WebSocket and the pages
  (every route of the app, read from ``app.routes``);
* ``<!-- operations -->``: per endpoint, its parameters, request bodies and response bodies as
  field tables from the schema, and a real request with the real answer: :data:`EXAMPLES` are
  sent, in order, to a fresh app in a temporary folder while the site builds (long lists are
  cut to their first items; the cut is said). The requests and answers are also shipped as
  ``reference/http-examples.json``, which the tests replay against a fresh app.
"""

from __future__ import annotations

import json
import shlex
import tempfile
from pathlib import Path
from typing import Any

PAGE = "reference/http.md"
SCHEMA = "reference/openapi.json"
EXAMPLES_FILE = "reference/http-examples.json"
MARK = "<!-- endpoints -->"
OPERATIONS = "<!-- operations -->"
ROOT = Path(__file__).resolve().parents[2]
SALAD = "docs/examples/salad/world.json"
KEEP_ITEMS = 2  # items kept of each list in a shown answer
KEEP_CHARS = 160  # characters kept of each long string in a shown answer

# Routes outside the schema, with what they are (a route with a docstring uses its first line).
PAGES = {
    "/": "the web demo page: pick a scenario, type, say or record an instruction, see the answer",
    "/openapi.json": "this API's OpenAPI 3.1 schema",
    "/docs": "interactive API docs (Swagger UI) from the server's own files",
    "/docs-assets": "the Swagger UI files `/docs` loads (no CDN)",
    "/static": "the web pages' scripts and styles",
    "/favicon.ico": "the icon",
    "/rate": "the rating page: three 7-point statements about a session's trial (`?session=ID`)",
    "/v1/sessions/{session_id}/listen": "a session's microphone, streamed: 16 kHz 16-bit PCM in binary "
                                        "messages; events `speech_started`, `speech_ended` and a "
                                        "`decision` per utterance ([streaming](../streaming.md))",
}

# The requests shown on the page, sent in this order. ``{sid}`` is the id of the session made
# by the first request that answers with one; ``{wav}`` is the audio of the last /v1/say.
EXAMPLES: list[dict[str, Any]] = [
    {"method": "GET", "path": "/healthz"},
    {"method": "GET", "path": "/v1/scenarios"},
    {"method": "GET", "path": "/v1/scenarios/kitchen-cereal-v0"},
    {"method": "GET", "path": "/v1/scenarios/kitchen-cereal-v0.png?command=fetch(cereal)"},
    {"method": "POST", "path": "/v1/infer",
     "json": {"scenario": "kitchen-cereal-v0", "transcript": "can you pass me the sugar"}},
    {"method": "POST", "path": "/v1/say", "json": {"text": "pass me the cereal", "noise": "pink", "snr": 10},
     "save": "say.wav"},
    {"method": "POST", "path": "/v1/infer", "form": {"scenario": "kitchen-cereal-v0"}, "file": "say.wav"},
    {"method": "POST", "path": "/v1/sessions", "world": SALAD},
    {"method": "POST", "path": "/v1/sessions/{sid}/actions",
     "json": {"actions": ["[Walk] <fridge> (1)", "[Open] <fridge> (1)"], "after": 0}},
    {"method": "POST", "path": "/v1/sessions/{sid}/instruction", "json": {"transcript": "can you get me the potato"}},
    {"method": "GET", "path": "/v1/sessions/{sid}"},
    {"method": "GET", "path": "/v1/ratings/statements"},
    {"method": "POST", "path": "/v1/sessions/{sid}/rating", "json": {"scores": [6, 5, 6], "rater": "p01"}},
    {"method": "DELETE", "path": "/v1/sessions/{sid}"},
    {"method": "POST", "path": "/v1/sessions/from-scenario", "json": {"scenario": "kitchen-cereal-v0", "n_actions": 3}},
]


def make_app(folder: str | Path) -> Any:
    from siftom.service.app import create_app

    return create_app(folder)


def openapi_schema() -> dict[str, Any]:
    """The service's OpenAPI schema (needs the ``serve`` extra)."""
    with tempfile.TemporaryDirectory() as d:
        return make_app(d).openapi()


# ----- routes ----------------------------------------------------------------------------------
def route_rows(app: Any) -> list[tuple[str, str, str]]:
    """(kind, path, what it is) for every route of ``app`` outside the schema: the WebSocket and
    the pages (mounts included), in the app's order."""
    from starlette.routing import Mount, WebSocketRoute

    rows = []
    for r in app.routes:
        path = getattr(r, "path", "")
        if getattr(r, "include_in_schema", False) and not isinstance(r, WebSocketRoute):
            continue
        kind = "WS" if isinstance(r, WebSocketRoute) else "files" if isinstance(r, Mount) else "GET"
        doc = (getattr(getattr(r, "endpoint", None), "__doc__", None) or "").strip().splitlines()
        rows.append((kind, path, PAGES.get(path) or (doc[0] if doc else "")))
    return rows


def endpoint_table(schema: dict[str, Any], app: Any | None = None) -> str:
    """A Markdown table: method, path, summary, one row per operation in the schema's order,
    then (with ``app``) the routes outside the schema."""
    rows = ["| method | path | what it does |", "|---|---|---|"]
    for path, ops in schema.get("paths", {}).items():
        for method, op in ops.items():
            if method.startswith("x-") or not isinstance(op, dict):
                continue
            text = _first_line(op).replace("|", "\\|")
            rows.append(f"| `{method.upper()}` | [`{path}`](#{anchor(method, path)}) | {text} |")
    if app is not None:
        for kind, path, text in route_rows(app):
            rows.append(f"| `{kind}` | `{path}` | {text} |")
    return "\n".join(rows)


def _first_line(op: dict[str, Any]) -> str:
    """The first paragraph of an operation's description, on one line."""
    text = (op.get("description") or op.get("summary") or "").strip().split("\n\n")[0]
    return " ".join(text.split()).replace("``", "`")


def anchor(method: str, path: str) -> str:
    """The heading id of an operation's section."""
    slug = "".join(c if c.isalnum() else "-" for c in f"{method} {path}".lower())
    return "-".join(part for part in slug.split("-") if part)


# ----- schema to field tables --------------------------------------------------------------------
def _resolve(schema: dict[str, Any], node: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in node:
        node = schema["components"]["schemas"][node["$ref"].rsplit("/", 1)[-1]]
    return node


def type_name(schema: dict[str, Any], node: dict[str, Any]) -> str:
    """A short type: ``string``, ``integer | null``, ``NBestItem[]``, ``"full" | "speech-only"``."""
    if "$ref" in node:
        return node["$ref"].rsplit("/", 1)[-1]
    if "anyOf" in node or "oneOf" in node:
        parts = [type_name(schema, n) for n in node.get("anyOf", node.get("oneOf", []))]
        if "enum" in node:  # an enum put beside the anyOf (the offered likelihoods)
            parts = [p for p in parts if p == "null"] + [" \\| ".join(json.dumps(v) for v in node["enum"])]
            parts.reverse()
        return " \\| ".join(dict.fromkeys(parts))
    if "enum" in node:
        return " \\| ".join(json.dumps(v) for v in node["enum"])
    kind = node.get("type", "any")
    if kind == "array":
        return f"{type_name(schema, node.get('items', {}))}[]"
    if kind == "string" and node.get("format") == "binary":
        return "file"
    return str(kind)


def _limits(node: dict[str, Any]) -> str:
    parts = []
    for sub in [node, *node.get("anyOf", [])]:
        for key, word in (("minimum", "≥"), ("maximum", "≤")):
            if key in sub:
                value = sub[key]
                parts.append(f"{word} {int(value) if float(value).is_integer() else value}")
        for key, word in (("minLength", "length ≥"), ("maxLength", "length ≤"), ("minItems", "items ≥"),
                          ("maxItems", "items ≤")):
            if key in sub:
                parts.append(f"{word} {sub[key]}")
    return ", ".join(dict.fromkeys(parts))


def field_rows(schema: dict[str, Any], node: dict[str, Any], prefix: str = "", depth: int = 0) -> list[str]:
    """Table rows ``| name | type | required | default | description |`` of an object schema;
    a field that is itself an object with properties is listed with its fields (``clarify.cost``)."""
    node = _resolve(schema, node)
    required = set(node.get("required", []))
    rows = []
    for name, prop in node.get("properties", {}).items():
        full = f"{prefix}{name}"
        desc = (prop.get("description") or "").replace("|", "\\|").replace("\n", " ")
        limits = _limits(prop)
        if limits:
            desc = f"{desc} ({limits})" if desc else limits
        default = json.dumps(prop["default"]) if "default" in prop else ""
        rows.append(f"| `{full}` | {type_name(schema, prop)} | {'yes' if name in required else ''} | "
                    f"{default.replace('|', chr(92) + '|')} | {desc} |")
        inner = _resolve(schema, prop)
        if depth < 1 and "$ref" in prop and inner.get("properties"):
            rows.extend(field_rows(schema, prop, f"{full}.", depth + 1))
    return rows


def field_table(schema: dict[str, Any], node: dict[str, Any]) -> str:
    rows = field_rows(schema, node)
    if not rows:
        return ""
    return "\n".join(["| field | type | required | default | description |", "|---|---|---|---|---|", *rows])


def operation_section(schema: dict[str, Any], method: str, path: str, op: dict[str, Any],
                      examples: list[dict[str, Any]]) -> str:
    out = [f"### `{method.upper()} {path}` {{#{anchor(method, path)}}}", ""]
    desc = (op.get("description") or op.get("summary") or "").strip()
    if desc:
        out += [desc.replace("``", "`"), ""]
    params = op.get("parameters", [])
    if params:
        out += ["**Parameters**", "", "| name | in | type | required | description |", "|---|---|---|---|---|"]
        for p in params:
            text = (p.get("description") or p.get("schema", {}).get("description") or "").replace("|", "\\|")
            out.append(f"| `{p['name']}` | {p['in']} | {type_name(schema, p.get('schema', {}))} | "
                       f"{'yes' if p.get('required') else ''} | {text} |")
        out.append("")
    for media, body in op.get("requestBody", {}).get("content", {}).items():
        node = body.get("schema", {})
        name = type_name(schema, node)
        out += [f"**Request body** (`{media}`, `{name}`)", ""]
        inner = _resolve(schema, node).get("description", "")
        if inner:
            out += [inner.replace("``", "`"), ""]
        table = field_table(schema, node)
        out += [table, ""] if table else []
    ok = {code: r for code, r in op.get("responses", {}).items() if code.startswith("2")}
    for code, resp in ok.items():
        contents = resp.get("content", {}) or {"": {}}
        for media, body in contents.items():
            node = body.get("schema", {})
            named = "$ref" in node
            what = f"`{media}`" + (f", `{type_name(schema, node)}`" if named else "") if media else "no body"
            text = resp.get("description", "")
            text = "" if text == "Successful Response" else f": {text}"
            out += [f"**Response {code}** ({what}){text}", ""]
            table = field_table(schema, node) if named else ""
            out += [table, ""] if table else []
    errors = [code for code in op.get("responses", {}) if code[0] in "45"]
    if errors:
        out += ["**Errors**: " + ", ".join(f"`{c}`" for c in errors) +
                " as problem details (`application/problem+json`: `type`, `title`, `status`, `detail`).", ""]
    for ex in examples:
        out += [example_text(ex), ""]
    return "\n".join(out)


# ----- real examples ----------------------------------------------------------------------------
def operation_of(app: Any, method: str, path: str) -> str:
    """The schema path of the route that serves ``method path`` (``/v1/sessions/{session_id}``)."""
    from starlette.routing import Match

    scope = {"type": "http", "method": method, "path": path.split("?")[0], "root_path": "",
             "query_string": b"", "headers": []}
    for r in app.routes:
        if getattr(r, "include_in_schema", False) and r.matches(scope)[0] == Match.FULL:
            return r.path.replace(":path}", "}")
    raise KeyError(f"{method} {path}: no route of the app serves it")


def run_examples(root: Path = ROOT) -> list[dict[str, Any]]:
    """Send :data:`EXAMPLES` to a fresh app in a temporary folder; each request with its answer."""
    from fastapi.testclient import TestClient

    out: list[dict[str, Any]] = []
    saved: dict[str, bytes] = {}
    sid = ""
    # reached as localhost: the server answers only to loopback and configured host names
    with tempfile.TemporaryDirectory() as d, TestClient(make_app(d), base_url="http://localhost",
                                                        raise_server_exceptions=True) as client:
        for ex in EXAMPLES:
            path = ex["path"].replace("{sid}", sid)
            body = ex.get("json")
            if "world" in ex:
                body = {"world": json.loads((root / ex["world"]).read_text(encoding="utf-8"))}
            if "file" in ex:
                r = client.request(ex["method"], path, data=ex["form"],
                                   files={"audio": (ex["file"], saved[ex["file"]], "audio/wav")})
            else:
                r = client.request(ex["method"], path, json=body)
            ctype = r.headers.get("content-type", "").split(";")[0]
            answer = r.json() if ctype.endswith("json") else None
            if isinstance(answer, dict) and not sid and isinstance(answer.get("id"), str) and "/sessions" in path:
                sid = answer["id"]
            if "save" in ex:
                saved[ex["save"]] = r.content
            out.append({"method": ex["method"], "path": path, "shown_path": ex["path"].replace("{sid}", "$SID"), "operation": operation_of(client.app, ex["method"], path),
                        "request": {k: ex[k] for k in ("json", "form", "file", "world") if k in ex},
                        "save": ex.get("save"),
                        "status": r.status_code, "content_type": ctype, "bytes": len(r.content),
                        "response": answer})
    return out


def shorten(value: Any) -> tuple[Any, bool]:
    """``value`` with each list cut to :data:`KEEP_ITEMS` items and each long string cut;
    True when something was cut."""
    if isinstance(value, dict):
        items = [(k, shorten(v)) for k, v in value.items()]
        return {k: v for k, (v, _) in items}, any(c for _, (_, c) in items)
    if isinstance(value, list):
        kept = [shorten(v) for v in value[:KEEP_ITEMS]]
        return [v for v, _ in kept], len(value) > KEEP_ITEMS or any(c for _, c in kept)
    if isinstance(value, str) and len(value) > KEEP_CHARS:
        return value[:KEEP_CHARS] + "…", True
    if isinstance(value, float):
        return round(value, 4), False
    return value, False


def pretty(value: Any, indent: int = 0, width: int = 96) -> str:
    """JSON with 2-space indents, a list or object on one line when it fits in ``width``."""
    flat = json.dumps(value, ensure_ascii=False)
    if len(flat) + indent <= width or not isinstance(value, (dict, list)) or not value:
        return flat
    pad = " " * (indent + 2)
    if isinstance(value, dict):
        items = [f"{pad}{json.dumps(k, ensure_ascii=False)}: {pretty(v, indent + 2, width)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    items = [pad + pretty(v, indent + 2, width) for v in value]
    return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"


def curl(ex: dict[str, Any]) -> str:
    req = ex["request"]
    shown = ex.get("shown_path", ex["path"])
    url = f'"localhost:8000{shown}"' if "$SID" in shown else shlex.quote(f"localhost:8000{shown}")
    head = "curl -s" if ex["method"] in ("GET", "POST") else f"curl -s -X {ex['method']}"
    if "world" in req:
        return (f"{head} {url} -H 'content-type: application/json' \\\n"
                f"    -d \"{{\\\"world\\\": $(cat {req['world']})}}\"")
    if "file" in req:
        fields = " ".join(f"-F {shlex.quote(f'{k}={v}')}" for k, v in req["form"].items())
        return f"{head} {url} {fields} -F audio=@{req['file']}"
    if "json" in req:
        out = f" -o {ex['save']}" if ex.get("save") else ""
        return f"{head} {url} -H 'content-type: application/json' \\\n    -d {shlex.quote(json.dumps(req['json']))}{out}"
    return f"{head} {url}"


def example_text(ex: dict[str, Any]) -> str:
    sid = ("; `$SID` is the `id` in the answer to `POST /v1/sessions`"
           if "$SID" in ex.get("shown_path", "") else "")
    lines = [f"Example (a real request to this version, answered while these docs were built{sid}):", "",
             "```console", f"$ {curl(ex)}", "```", ""]
    if ex["response"] is None:
        what = f"{ex['bytes']:,} bytes of `{ex['content_type']}`" if ex["bytes"] else "no body"
        lines.append(f"Answer: `{ex['status']}`, {what}.")
        return "\n".join(lines)
    shown, cut = shorten(ex["response"])
    note = f" (lists cut to their first {KEEP_ITEMS} items, long strings cut)" if cut else ""
    lines += [f"Answer: `{ex['status']}`{note}:", "", "```json", pretty(shown), "```"]
    return "\n".join(lines)


def operations(schema: dict[str, Any], examples: list[dict[str, Any]]) -> str:
    out = []
    for path, ops in schema.get("paths", {}).items():
        for method, op in ops.items():
            if method.startswith("x-") or not isinstance(op, dict):
                continue
            mine = [e for e in examples if e["operation"] == path and e["method"] == method.upper()]
            out.append(operation_section(schema, method, path, op, mine))
    return "\n".join(out)


# ----- MkDocs ------------------------------------------------------------------------------------
_CACHE: dict[str, Any] = {}


def _built() -> tuple[dict[str, Any], Any, list[dict[str, Any]]]:
    if not _CACHE:
        with tempfile.TemporaryDirectory() as d:
            app = make_app(d)
            _CACHE["schema"] = app.openapi()
            _CACHE["app"] = app
        _CACHE["examples"] = run_examples()
    return _CACHE["schema"], _CACHE["app"], _CACHE["examples"]


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill the endpoint table and the operations into the HTTP page."""
    if page.file.src_uri != PAGE or MARK not in markdown:
        return markdown
    schema, app, examples = _built()
    markdown = markdown.replace(MARK, endpoint_table(schema, app))
    return markdown.replace(OPERATIONS, operations(schema, examples))


def on_files(files: Any, config: Any) -> Any:
    """Ship the full schema (``reference/openapi.json``) and the examples with the site."""
    from mkdocs.structure.files import File

    schema, _, examples = _built()
    files.append(File.generated(config, SCHEMA, content=json.dumps(schema, indent=2) + "\n"))
    files.append(File.generated(config, EXAMPLES_FILE, content=json.dumps(examples, indent=2) + "\n"))
    return files
