"""A chunked multipart upload over the body limit is a 413 (as with Content-Length), not a 400."""

from __future__ import annotations

import httpx

from siftom.service.app import create_app
from siftom.service.local_server import serve_in_thread
from siftom.service.runtime import ServiceSettings

LIMIT = 64 * 1024


def _chunks(boundary: str, size: int):
    yield (f"--{boundary}\r\nContent-Disposition: form-data; name=\"scenario\"\r\n\r\nkitchen-cereal-v0\r\n"
           f"--{boundary}\r\nContent-Disposition: form-data; name=\"audio\"; filename=\"a.wav\"\r\n"
           "Content-Type: audio/wav\r\n\r\n").encode()
    for _ in range(size // 8192):
        yield b"\0" * 8192
    yield f"\r\n--{boundary}--\r\n".encode()


def test_chunked_multipart_over_the_limit_is_413(tmp_path):
    app = create_app(tmp_path, ServiceSettings(max_body_bytes=LIMIT))
    with serve_in_thread(app) as url, httpx.Client(base_url=url, timeout=30) as c:
        r = c.post("/v1/infer", content=_chunks("xyz", 4 * LIMIT),
                   headers={"content-type": "multipart/form-data; boundary=xyz"})
        assert "content-length" not in r.request.headers  # really chunked
        assert r.status_code == 413, r.text
        assert r.headers["content-type"].startswith("application/problem+json")
