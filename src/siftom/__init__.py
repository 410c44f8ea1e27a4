"""siftom: follow noisy spoken instructions pragmatically (SIFToM).

Bayesian inverse planning over a symbolic scene combined with instruction likelihoods
computed from what was heard (transcripts, N-best lists or the audio itself).

From a recording to the posterior in one call::

    import siftom

    post = siftom.listen("say.wav", scenario="kitchen-cereal-v0")
    post.command

The names below are loaded on first use (``siftom.api``), so ``import siftom`` stays light.
"""

from __future__ import annotations

from typing import Any

__version__ = "0.2.0"

_API = ("listen", "infer_scenario", "infer_actions", "make_instruction", "transcribe_for", "get_model")
__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    if name in _API:
        from siftom import api

        return getattr(api, name)
    raise AttributeError(f"module 'siftom' has no attribute {name!r}")
