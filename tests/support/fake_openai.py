"""A local OpenAI-compatible test server: records requests, replays scripted answers.

Usage (the ``fake_openai`` fixture in tests/conftest.py starts one per test)::

    server = FakeOpenAI().start()
    server.script("chat/completions", Reply.error(429), Reply.json(chat_answer("yes")))
    server.on("completions", echo_logprobs(lambda text, offsets: [-1.0] * len(offsets)))
    ... client with base_url=server.url ...
    server.requests[0].body, server.paths()
    server.stop()

Per endpoint (path relative to ``/v1``, e.g. "completions", "chat/completions", "models"):
scripted replies are served first, in order, then the endpoint's handler (``on``), else 404
(an endpoint the server "does not offer"). A reply can be JSON, raw bytes (malformed bodies),
an HTTP error with a status, a delay (client timeouts), or a function of the request.
"""

from __future__ import annotations

import json
import re
import threading
import time
from collections import defaultdict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass
class RecordedRequest:
    """One request the server received."""

    method: str
    path: str  # relative to /v1, e.g. "chat/completions"
    headers: dict[str, str]
    body: Any  # parsed JSON (None for GET or a body that is not JSON)
    raw: bytes = b""


@dataclass
class Reply:
    """A scripted answer."""

    status: int = 200
    body: bytes = b"{}"
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0

    @classmethod
    def json(cls, data: Any, status: int = 200, **headers: str) -> Reply:
        return cls(status, json.dumps(data).encode(), {"Content-Type": "application/json", **headers})

    @classmethod
    def error(cls, status: int, message: str = "scripted error", **headers: str) -> Reply:
        return cls.json({"error": {"message": message, "code": status}}, status, **headers)

    @classmethod
    def malformed(cls, body: bytes = b"{not json") -> Reply:
        return cls(200, body, {"Content-Type": "application/json"})

    @classmethod
    def slow(cls, delay_s: float, data: Any | None = None) -> Reply:
        """Answer after ``delay_s`` (longer than the client's timeout to script a timeout)."""
        r = cls.json(data if data is not None else {})
        r.delay_s = delay_s
        return r


Handler = Callable[[RecordedRequest], Reply]


class FakeOpenAI:
    """A threaded HTTP server on 127.0.0.1:<free port> that speaks the OpenAI wire format."""

    def __init__(self, models: tuple[str, ...] = ("fake",)) -> None:
        self.requests: list[RecordedRequest] = []
        self._scripts: dict[str, deque[Reply | Handler]] = defaultdict(deque)
        self._handlers: dict[str, Handler] = {}
        self._lock = threading.Lock()
        self._httpd: ThreadingHTTPServer | None = None
        self.on("models", lambda _r: Reply.json({"object": "list", "data": [
            {"id": m, "object": "model"} for m in models]}))

    # --- scripting
    def script(self, path: str, *replies: Reply | Handler) -> FakeOpenAI:
        """Queue replies for ``path``; each is used once, before the handler."""
        with self._lock:
            self._scripts[path.strip("/")].extend(replies)
        return self

    def on(self, path: str, handler: Handler | None) -> FakeOpenAI:
        """The handler for ``path`` once its script is used up (None: the path 404s)."""
        with self._lock:
            if handler is None:
                self._handlers.pop(path.strip("/"), None)
            else:
                self._handlers[path.strip("/")] = handler
        return self

    def paths(self) -> list[str]:
        """Paths of the recorded requests, in order."""
        return [r.path for r in self.requests]

    def bodies(self, path: str) -> list[Any]:
        """Bodies of the recorded requests to ``path``."""
        return [r.body for r in self.requests if r.path == path.strip("/")]

    # --- lifecycle
    @property
    def url(self) -> str:
        """The API root to give a client, e.g. ``http://127.0.0.1:43123/v1``."""
        assert self._httpd is not None, "start() the server first"
        return f"http://127.0.0.1:{self._httpd.server_address[1]}/v1"

    def start(self) -> FakeOpenAI:
        server = self

        class _H(BaseHTTPRequestHandler):
            def _serve(self, method: str) -> None:
                n = int(self.headers.get("Content-Length") or 0)
                raw = self.rfile.read(n) if n else b""
                try:
                    body = json.loads(raw) if raw else None
                except (json.JSONDecodeError, UnicodeDecodeError):  # multipart, binary: see ``form``
                    body = None
                path = self.path.split("?", 1)[0]
                path = path[len("/v1"):] if path.startswith("/v1") else path
                req = RecordedRequest(method, path.strip("/"), dict(self.headers.items()), body, raw)
                reply = server._next(req)
                if reply.delay_s:
                    time.sleep(reply.delay_s)
                try:
                    self.send_response(reply.status)
                    for k, v in reply.headers.items():
                        self.send_header(k, v)
                    self.send_header("Content-Length", str(len(reply.body)))
                    self.end_headers()
                    self.wfile.write(reply.body)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout)

            def do_POST(self) -> None:  # noqa: N802 - http.server API
                self._serve("POST")

            def do_GET(self) -> None:  # noqa: N802
                self._serve("GET")

            def log_message(self, *args: Any) -> None:
                pass

        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), _H)
        self._httpd.daemon_threads = True
        threading.Thread(target=self._httpd.serve_forever, kwargs={"poll_interval": 0.02},
                         daemon=True).start()
        return self

    def stop(self) -> None:
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
            self._httpd = None

    def __enter__(self) -> FakeOpenAI:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _next(self, req: RecordedRequest) -> Reply:
        with self._lock:
            self.requests.append(req)
            queue = self._scripts.get(req.path)
            item: Reply | Handler | None = queue.popleft() if queue else self._handlers.get(req.path)
        if item is None:
            return Reply.error(404, f"no such endpoint /v1/{req.path}")
        return item(req) if callable(item) else item


# ----------------------------------------------------------------------------- answer builders

def split_tokens(text: str) -> list[str]:
    """A crude tokenizer: words with their leading space, and runs of whitespace."""
    return re.findall(r"\s*\S+|\s+", text)


def echo_logprobs(logprob: Callable[[str, int, str], float | None]) -> Handler:
    """A ``/completions`` handler for echo=True scoring.

    ``logprob(full_text, offset, token)`` gives each echoed token's log-prob (None allowed).
    """

    def handle(req: RecordedRequest) -> Reply:
        prompts = req.body["prompt"] if isinstance(req.body["prompt"], list) else [req.body["prompt"]]
        choices = []
        for i, text in enumerate(prompts):
            tokens = split_tokens(text)
            offsets, pos = [], 0
            for t in tokens:
                offsets.append(pos)
                pos += len(t)
            values = [None] + [logprob(text, o, t) for o, t in zip(offsets[1:], tokens[1:], strict=True)]
            choices.append({"index": i, "text": text, "finish_reason": "length",
                            "logprobs": {"tokens": tokens, "token_logprobs": values, "text_offset": offsets}})
        return Reply.json({"object": "text_completion", "model": req.body.get("model"), "choices": choices})

    return handle


def chat_answer(*contents: str, top_logprobs: list[list[tuple[str, float]]] | None = None,
                model: str = "fake") -> dict[str, Any]:
    """A chat completion with one choice per content; optional first-token top log-probs
    (``top_logprobs[k]`` lists (token, logprob) for choice k's first token)."""
    choices = []
    for k, text in enumerate(contents):
        choice: dict[str, Any] = {"index": k, "finish_reason": "stop",
                                  "message": {"role": "assistant", "content": text}}
        if top_logprobs is not None:
            alts = top_logprobs[k]
            choice["logprobs"] = {"content": [{"token": alts[0][0], "logprob": alts[0][1],
                                               "top_logprobs": [{"token": t, "logprob": v} for t, v in alts]}]}
        choices.append(choice)
    return {"object": "chat.completion", "model": model, "choices": choices}


def form(req: RecordedRequest) -> tuple[list[tuple[str, str]], dict[str, bytes]]:
    """The fields (name, value) and files (name -> bytes) of a multipart/form-data request."""
    from email.parser import BytesParser
    from email.policy import HTTP

    head = f"Content-Type: {req.headers.get('Content-Type', '')}\r\n\r\n".encode()
    msg = BytesParser(policy=HTTP).parsebytes(head + req.raw)
    fields, files = [], {}
    for part in msg.iter_parts():
        name = part.get_param("name", header="content-disposition")
        data = part.get_payload(decode=True) or b""
        if part.get_filename():
            files[name] = data
        else:
            fields.append((name, data.decode()))
    return fields, files


def transcription_answer(text: str, avg_logprob: float = -0.3, no_speech_prob: float = 0.01,
                         words: list[tuple[str, float, float]] | None = None) -> dict[str, Any]:
    """A ``/audio/transcriptions`` verbose_json answer with one segment (and optional word times)."""
    out: dict[str, Any] = {"task": "transcribe", "language": "english", "duration": 2.0, "text": text,
                           "segments": [{"id": 0, "start": 0.0, "end": 2.0, "text": text,
                                         "tokens": list(range(len(text.split()) + 1)),
                                         "avg_logprob": avg_logprob, "no_speech_prob": no_speech_prob}]}
    if words is not None:
        out["words"] = [{"word": w, "start": a, "end": b} for w, a, b in words]
    return out
