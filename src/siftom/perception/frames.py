"""Camera frames: read JPEG/PNG/WebP/GIF bytes, hash them, and encode them as data URLs.

A frame's SHA-256 is half of the perception cache key (the prompt is the other half), so the
same picture asked the same question is answered from the cache.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from siftom.errors import PerceptionError

MAX_FRAME_BYTES = 20 * 1024 * 1024  # the common limit of hosted vision APIs per image

# magic bytes -> MIME type
_MAGIC = (
    (b"\x89PNG\r\n\x1a\n", "image/png"),
    (b"\xff\xd8\xff", "image/jpeg"),
    (b"GIF87a", "image/gif"),
    (b"GIF89a", "image/gif"),
)


def sniff_mime(data: bytes) -> str | None:
    """The image type from the first bytes (PNG, JPEG, GIF, WebP), or None."""
    for magic, mime in _MAGIC:
        if data.startswith(magic):
            return mime
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "image/webp"
    return None


@dataclass(frozen=True)
class Frame:
    """One camera image: its bytes, MIME type, a name for messages and its SHA-256."""

    data: bytes = field(repr=False)
    mime: str
    name: str = "<bytes>"

    def __post_init__(self) -> None:
        if not isinstance(self.data, bytes | bytearray) or not self.data:
            raise PerceptionError(f"{self.name}: the frame is empty; give a JPEG or PNG image")

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.data).hexdigest()

    def data_url(self) -> str:
        """``data:image/png;base64,...``: how OpenAI-compatible chat APIs take an inline image."""
        return f"data:{self.mime};base64,{base64.b64encode(self.data).decode('ascii')}"

    @classmethod
    def from_bytes(cls, data: bytes, name: str = "<bytes>") -> Frame:
        """A frame from image bytes; PerceptionError when they are not a JPEG/PNG/WebP/GIF image."""
        if len(data) > MAX_FRAME_BYTES:
            raise PerceptionError(f"{name}: {len(data)} bytes is more than {MAX_FRAME_BYTES // 2**20} MB; "
                                  "resize the image first")
        mime = sniff_mime(bytes(data[:16]))
        if mime is None:
            raise PerceptionError(f"{name}: not a JPEG, PNG, WebP or GIF image (first bytes {bytes(data[:8])!r}); "
                                  "give camera frames as image files")
        return cls(bytes(data), mime, name)

    @classmethod
    def from_path(cls, path: str | Path) -> Frame:
        """A frame from an image file."""
        p = Path(path)
        if not p.is_file():
            raise PerceptionError(f"{p}: no such image file; give JPEG or PNG frames")
        if p.stat().st_size > MAX_FRAME_BYTES:
            raise PerceptionError(f"{p}: larger than {MAX_FRAME_BYTES // 2**20} MB; resize the image first")
        return cls.from_bytes(p.read_bytes(), str(p))

    @classmethod
    def from_data_url(cls, text: str, name: str = "<data url>") -> Frame:
        """A frame from ``data:image/...;base64,...`` or from bare base64."""
        payload = text.split(",", 1)[1] if text.startswith("data:") and "," in text else text
        try:
            data = base64.b64decode(payload, validate=True)
        except (binascii.Error, ValueError):
            raise PerceptionError(f"{name}: not base64; send the image as a data URL "
                                  "(data:image/png;base64,...) or bare base64") from None
        return cls.from_bytes(data, name)
