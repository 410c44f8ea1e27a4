"""The evaluator's recognisers, one per (engine, vocabulary) in each process."""

from __future__ import annotations

import hashlib
from typing import Any

_ENGINES: dict[tuple[str, str], Any] = {}


def engine(name: str, vocabulary: tuple[str, ...]) -> Any:
    """The ASR engine ``name`` (a scene engine built on ``vocabulary``), built once per process."""
    from siftom.speech.asr.base import get_engine, is_scene_engine

    scene = is_scene_engine(name)
    key = (name, hashlib.sha1("\n".join(vocabulary).encode()).hexdigest() if scene else "")
    if key not in _ENGINES:
        _ENGINES[key] = get_engine(name, vocabulary=vocabulary if scene else None)
    return _ENGINES[key]
