"""Limits of the streaming endpoint ``WS /v1/sessions/{id}/listen`` (docs/streaming.md)."""

from __future__ import annotations

from dataclasses import dataclass

from siftom.errors import OptionsError

# WebSocket close codes of the streaming endpoint (docs/streaming.md lists them with the fix).
CLOSE_NORMAL = 1000  # the client sent {"type": "end"}; every utterance was answered
CLOSE_UNSUPPORTED = 1003  # a text message that is not a command, or PCM with an odd number of bytes
CLOSE_TOO_BIG = 1009  # one binary message over max_chunk_bytes
CLOSE_INTERNAL = 1011  # a bug: the server could not go on
CLOSE_BUSY = 1013  # max_streams streams already open, or utterances waiting beyond max_pending
CLOSE_UNKNOWN_SESSION = 4404  # no such session (deleted or expired)
CLOSE_IDLE = 4408  # no message for max_idle_s
CLOSE_ALREADY_STREAMING = 4409  # another stream is open on this session
CLOSE_BAD_PARAMETER = 4422  # a query parameter is invalid (top, threshold, cost, partial)


@dataclass(frozen=True)
class StreamLimits:
    """Limits of the streaming endpoint (``siftom serve --max-streams ...``).

    Attributes:
        max_streams: streams open at once on this server (more: closed with 1013 at once).
        max_utterance_s: speech longer than this is cut and answered, and listening goes on.
        max_idle_s: a stream that sends nothing for this long is closed (4408).
        max_pending: utterances waiting for their answer while the stream goes on; one more
            closes the stream with 1013 (the client sends speech faster than it is answered).
        max_chunk_bytes: the largest binary message (1009 above); 64 KiB is 2 s of audio.
    """

    max_streams: int = 8
    max_utterance_s: float = 15.0
    max_idle_s: float = 30.0
    max_pending: int = 2
    max_chunk_bytes: int = 64 * 1024

    def __post_init__(self) -> None:
        if min(self.max_streams, self.max_pending) < 1:
            raise OptionsError("max_streams and max_pending must be >= 1")
        if not 1.0 <= self.max_utterance_s <= 120.0:
            raise OptionsError(f"max_utterance_s must be in [1, 120] s, got {self.max_utterance_s}")
        if not self.max_idle_s > 0:
            raise OptionsError(f"max_idle_s must be > 0 s, got {self.max_idle_s}")
        if not 1024 <= self.max_chunk_bytes <= 16 * 2**20:
            raise OptionsError(f"max_chunk_bytes must be in [1024, 16 MiB], got {self.max_chunk_bytes}")
