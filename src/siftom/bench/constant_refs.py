"""A constant of the registry (:mod:`siftom.bench.constants`): the entry, where its value comes
from, and its current value read by import from the reference that names it (``module.NAME``,
``module.Class.field`` for a dataclass default, ``module.callable(param)`` for a keyword default).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from dataclasses import dataclass
from typing import Any

from siftom.errors import SiftomError

NOT_RECORDED = "not recorded"
# where a value comes from
TUNED = "siftom, tuned"        # chosen by measuring on a data set
SET = "siftom, set"            # chosen by reasoning or a literature value, not fitted
MEASURED = "siftom, measured"  # a measurement stored as a constant
WHISPER = "Whisper's default"
SILERO = "Silero's default"
PAPER = "paper"
ORIGINS = (TUNED, SET, MEASURED, WHISPER, SILERO, PAPER)


@dataclass(frozen=True)
class Constant:
    """One registry entry (module docstring)."""

    ref: str
    does: str
    chosen_on: str
    refit: str
    origin: str = TUNED
    doc: str = ""


def _resolve_path(path: str) -> Any:
    parts = path.split(".")
    for i in range(len(parts) - 1, 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for name in parts[i:]:
            if dataclasses.is_dataclass(obj) and isinstance(obj, type):
                fields = {f.name: f for f in dataclasses.fields(obj)}
                if name in fields:
                    f = fields[name]
                    if f.default is not dataclasses.MISSING:
                        obj = f.default
                        continue
                    if f.default_factory is not dataclasses.MISSING:
                        obj = f.default_factory()
                        continue
                    raise SiftomError(f"{path}: field {name!r} has no default")
            if not hasattr(obj, name):
                raise SiftomError(f"{path}: {name!r} does not exist (renamed or removed?)")
            obj = getattr(obj, name)
        return obj
    raise SiftomError(f"{path}: no importable module")


def value_of(ref: str) -> Any:
    """The current value of ``ref``: ``mod.NAME``, ``mod.Class.field`` or ``mod.callable(param)``."""
    if ref.endswith(")"):
        path, _, param = ref[:-1].partition("(")
        target = _resolve_path(path)
        try:
            p = inspect.signature(target).parameters[param]
        except (KeyError, TypeError, ValueError) as e:
            raise SiftomError(f"{ref}: {path} has no parameter {param!r}") from e
        if p.default is inspect.Parameter.empty:
            raise SiftomError(f"{ref}: parameter {param!r} has no default")
        return p.default
    return _resolve_path(ref)


def fmt(v: Any) -> str:
    """A value as the page shows it."""
    if isinstance(v, bool) or v is None:
        return repr(v)
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, tuple | list):
        return "(" + ", ".join(fmt(x) for x in v) + ")"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{fmt(k)}: {fmt(x)}" for k, x in v.items()) + "}"
    return repr(v)
