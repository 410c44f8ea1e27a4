"""What a client of ``WS /v1/sessions/{id}/listen`` declares and sends besides audio: the query
parameters (:class:`StreamParams`), its PCM format (:class:`PcmIn`) and the text commands
(:class:`StreamCommand`); anything invalid closes the stream (:class:`StreamClosed`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from siftom.assist.clarify import ClarifyPolicy
from siftom.errors import SiftomError
from siftom.service.problems import ProblemError
from siftom.service.schemas import MAX_TEXT_CHARS
from siftom.service.stream_settings import CLOSE_BAD_PARAMETER, CLOSE_TOO_BIG, CLOSE_UNSUPPORTED
from siftom.speech.audio import SAMPLE_RATE

# the query parameters of WS /v1/sessions/{id}/listen (``token`` is taken out before: access.py)
QUERY_PARAMS = ("top", "threshold", "cost", "nbest", "partial", "rate", "channels", "takeover")
MAX_CHANNELS = 8
RATES = (8000, 192_000)  # the sample rates a client may declare (resampled to 16 kHz)
MAX_COMMAND_ACTIONS = 100
MAX_COMMAND_CHARS = MAX_COMMAND_ACTIONS * (MAX_TEXT_CHARS + 8) + 100  # a text message's JSON, at most


class StreamClosed(Exception):
    """Close the WebSocket with ``code`` and ``reason`` (at most 123 bytes)."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code, self.reason = code, reason.encode()[:123].decode(errors="ignore")


def _check_names(query: Mapping[str, str]) -> None:
    """4422 naming a query parameter this endpoint does not know (a typo would go unnoticed)."""
    for name in query:
        if name not in QUERY_PARAMS:
            raise StreamClosed(CLOSE_BAD_PARAMETER, f"unknown query parameter {name[:24]!r}; "
                               f"accepted: {', '.join(QUERY_PARAMS)}")


def _number(query: Mapping[str, str], name: str, default: float, lo: float, hi: float, kind: type = float) -> Any:
    raw = query.get(name)
    if raw is None:
        return kind(default)
    try:
        value = kind(raw)
    except ValueError:
        raise StreamClosed(CLOSE_BAD_PARAMETER, f"{name}={raw[:24]!r} is not a number") from None
    if not lo <= value <= hi:
        raise StreamClosed(CLOSE_BAD_PARAMETER, f"{name} must be in [{lo:g}, {hi:g}], got {raw[:24]}")
    return value


@dataclass(frozen=True)
class StreamParams:
    """A stream's query parameters.

    Attributes:
        top: commands in each answer; policy: when to ask a clarifying question;
        nbest: recogniser hypotheses per utterance; partial: send ``heard`` events;
        rate, channels: the client's PCM format; takeover: replace the session's open stream.
    """

    top: int
    policy: ClarifyPolicy
    nbest: int
    partial: bool
    rate: int = SAMPLE_RATE
    channels: int = 1
    takeover: bool = False

    @classmethod
    def from_query(cls, query: Mapping[str, str], top_default: int, nbest_default: int) -> StreamParams:
        """Read the query string (4422 when invalid or unknown); left out, top and the N-best size
        are the settings (infer.top, infer.nbest), the format 16 kHz mono."""
        _check_names(query)

        def number(name: str, default: float, lo: float, hi: float, kind: type = float) -> Any:
            return _number(query, name, default, lo, hi, kind)

        top = number("top", min(top_default, 20), 1, 20, int)
        policy = ClarifyPolicy(number("threshold", ClarifyPolicy().threshold, 0, 1),
                               number("cost", ClarifyPolicy().cost, 0, 1))
        nbest = number("nbest", min(nbest_default, 10), 1, 10, int)
        partial = number("partial", 0, 0, 1, int) == 1
        return cls(top, policy, nbest, partial, number("rate", SAMPLE_RATE, *RATES, int),
                   number("channels", 1, 1, MAX_CHANNELS, int), number("takeover", 0, 0, 1, int) == 1)


class PcmIn:
    """The client's 16-bit little-endian PCM (``rate`` Hz, ``channels`` interleaved) as the 16 kHz
    mono the detector takes: channels averaged, then resampled with soxr (streaming, so chunks
    of any size join up without clicks)."""

    def __init__(self, rate: int = SAMPLE_RATE, channels: int = 1) -> None:
        import soxr

        self.rate, self.channels = rate, channels
        self.frame_bytes = 2 * channels
        self._soxr = soxr.ResampleStream(rate, SAMPLE_RATE, 1, dtype="float32") if rate != SAMPLE_RATE else None

    def convert(self, data: bytes) -> Any:
        """One binary message -> 16 kHz mono (the bytes as they are when they are that already)."""
        if self.channels == 1 and self._soxr is None:
            return data
        import numpy as np

        x = np.frombuffer(data, dtype="<i2").astype(np.float32) / 32768.0
        if self.channels > 1:
            x = x.reshape(-1, self.channels).mean(axis=1)
        return x if self._soxr is None else self._soxr.resample_chunk(x)

    def flush(self) -> Any:
        """What the resampler still holds, at the end of the stream."""
        import numpy as np

        if self._soxr is None:
            return np.zeros(0, dtype=np.float32)
        return self._soxr.resample_chunk(np.zeros(0, dtype=np.float32), last=True)


@dataclass(frozen=True)
class StreamCommand:
    """A text message: ``{"type": "end"}`` or ``{"type": "actions", "actions": [lines]}``."""

    end: bool
    actions: tuple[str, ...] = ()

    @classmethod
    def from_text(cls, text: str | None) -> StreamCommand:
        """The command in ``text``; anything else closes the stream (1003)."""
        from siftom.safejson import loads

        if text is not None and len(text) > MAX_COMMAND_CHARS:  # closed before it is parsed
            raise StreamClosed(CLOSE_TOO_BIG, f"a text message of {len(text)} characters; send at most "
                               f"{MAX_COMMAND_CHARS} ({MAX_COMMAND_ACTIONS} action lines)")
        try:
            obj = loads(text or "", "a text message")  # too deep, too long a number: not a command either
        except SiftomError:
            obj = None
        if isinstance(obj, dict) and obj.get("type") == "end":
            return cls(True)
        if isinstance(obj, dict) and obj.get("type") == "actions":
            acts = obj.get("actions")
            if (isinstance(acts, list) and all(isinstance(a, str) for a in acts)
                    and len(acts) <= MAX_COMMAND_ACTIONS):
                return cls(False, tuple(acts))
        raise StreamClosed(CLOSE_UNSUPPORTED, 'text messages are {"type": "end"} or {"type": "actions", '
                           '"actions": [lines]}; send audio as binary messages')

    def check_lines(self) -> None:
        """A 422 (an ``error`` event; the stream goes on) for an action line longer than HTTP takes."""
        for k, line in enumerate(self.actions):
            if len(line) > MAX_TEXT_CHARS:
                raise ProblemError(422, "validation", f"actions[{k}] has {len(line)} characters; an action line "
                                   f"has at most {MAX_TEXT_CHARS}, as over HTTP; nothing was added")
