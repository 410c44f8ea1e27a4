"""siftom: follow noisy spoken instructions pragmatically (SIFToM).

Bayesian inverse planning over a symbolic scene combined with instruction likelihoods
computed from what was heard (transcripts, N-best lists or the audio itself).

``siftom.listen(audio, scenario=...)`` goes from a recording to the posterior in one call.
"""

from typing import Any

__version__ = "0.1.0"
__all__ = ["listen"]


def listen(*args: Any, **kwargs: Any) -> Any:
    """Audio in, posterior out: see :func:`siftom.inference.listen.listen`."""
    from siftom.inference.listen import listen as _listen

    return _listen(*args, **kwargs)
