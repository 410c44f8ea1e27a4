"""One root error with named subclasses; every message says what was wrong and how to fix it."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class SiftomError(Exception):
    """Root of every error siftom raises on purpose."""


class SceneGraphError(SiftomError):
    """A scene graph file or object is malformed."""


class IllegalActionError(SiftomError):
    """An action cannot be applied in a state; the message says why."""


class UnknownNameError(SiftomError, KeyError):
    """A registry lookup failed (domain, scenario, voice, engine, model ...)."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0]) if self.args else ""


class CommandParseError(SiftomError, ValueError):
    """A robot command string is malformed or not valid for the scenario."""


class ObservationError(SiftomError, ValueError):
    """An observation (scene, actions, instruction) is invalid."""


class OptionsError(SiftomError, ValueError):
    """An option (a parameter of a model, planner or run) is out of its range."""


class SettingsError(OptionsError):
    """A setting is unknown or its value is invalid (the message names the key and the fix)."""


class AudioError(SiftomError, ValueError):
    """An audio file cannot be read or is unusable."""


class BackendUnavailableError(SiftomError):
    """An optional backend is not installed or not configured."""


class DatasetError(SiftomError, ValueError):
    """A benchmark dataset or results folder is malformed."""


class NotYoursError(DatasetError):
    """A person's key is missing or does not match: their recordings and answers are not yours (403)."""


def unknown_name(kind: str, name: str, known: Iterable[str]) -> UnknownNameError:
    """Build an UnknownNameError that lists close matches and all valid names."""
    known = sorted(known)
    close = difflib.get_close_matches(name, known, n=3)
    hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return UnknownNameError(f"unknown {kind} {name!r}.{hint} Valid: {', '.join(known)}")


def missing_extra(extra: str, package: str) -> BackendUnavailableError:
    """Error for an optional dependency that is not installed."""
    return BackendUnavailableError(
        f"{package} is not installed; install it with: pip install \"siftom[{extra}]\""
    )


class PerceptionError(SiftomError):
    """A vision-language model's answer could not be turned into a valid world or action log."""
