"""Limits of the streaming endpoint ``WS /v1/sessions/{id}/listen`` (docs/streaming.md)."""

from __future__ import annotations

from siftom.options import StreamLimits

# WebSocket close codes of the streaming endpoint (docs/streaming.md lists them with the fix).
CLOSE_NORMAL = 1000  # the client sent {"type": "end"}; every utterance was answered
CLOSE_UNSUPPORTED = 1003  # a text message that is not a command, or PCM with an odd number of bytes
CLOSE_TOO_BIG = 1009  # one binary message over max_chunk_bytes
CLOSE_INTERNAL = 1011  # a bug: the server could not go on
CLOSE_BUSY = 1013  # max_streams streams already open, or utterances waiting beyond max_pending
CLOSE_UNKNOWN_SESSION = 4404  # no such session (deleted or expired)
CLOSE_IDLE = 4408  # no message for max_idle_s, or audio lagging wall time by more than the lag allowance
MAX_LAG_S = 10.0  # a stream's audio may fall behind wall time by this much (or max_idle_s, if less)
CLOSE_ALREADY_STREAMING = 4409  # another stream is open on this session, or took this one over
CLOSE_BAD_PARAMETER = 4422  # a query parameter is invalid or unknown

__all__ = ["StreamLimits"]
