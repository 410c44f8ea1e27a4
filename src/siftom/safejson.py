"""JSON and text from outside (files, vision-model answers, endpoints) read without surprises.

``json.loads`` raises RecursionError on a few thousand nested brackets and ValueError on an
integer of more than 4300 digits, and a value nested a few hundred levels deep breaks the
recursive code that reads it afterwards (schema checks, repr). :func:`loads` turns each of
these into the caller's :class:`~siftom.errors.SiftomError` subclass, with what was wrong.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from siftom.errors import ObservationError, SiftomError

MAX_DEPTH = 64  # deeper than any world, scene graph or model answer siftom reads


def depth(value: Any) -> int:
    """How deeply lists and objects nest in ``value`` (0 for a scalar); iterative, so never recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        elif not isinstance(v, list):
            continue
        deepest = max(deepest, d)
        if d > MAX_DEPTH:
            break
        stack.extend((x, d + 1) for x in v)
    return deepest


def loads(text: str | bytes, what: str, error: type[SiftomError] = ObservationError,
          max_depth: int = MAX_DEPTH) -> Any:
    """Parse ``text`` as JSON; raise ``error`` naming ``what`` and the problem instead of any other exception."""
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise error(f"{what} is not UTF-8 text (byte {exc.start}: {text[exc.start:exc.start + 1]!r}); "
                        "save it as UTF-8") from None
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{what} is not JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None
    except RecursionError:
        raise error(f"{what} nests lists or objects too deeply to read (at most {max_depth} levels)") from None
    except ValueError as exc:  # an integer longer than Python converts (4300 digits)
        why = "an integer with too many digits" if "digits" in str(exc) else f"a value that cannot be read ({exc})"
        raise error(f"{what} holds {why[:160]}") from None
    if depth(value) > max_depth:
        raise error(f"{what} nests lists or objects more than {max_depth} levels deep")
    return value


def read_text(path: str | Path, what: str, error: type[SiftomError] = ObservationError) -> str:
    """A user's text file as a string; ``error`` naming ``what`` when it is missing or not UTF-8."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{what} {str(path)!r} is not UTF-8 text (bad byte at offset {exc.start}); "
                    "save it as UTF-8") from None
    except OSError as exc:
        raise error(f"cannot read {what} {str(path)!r}: {exc.strerror or exc}") from None
