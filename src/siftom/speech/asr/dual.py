"""Two decodes of one utterance, one N-best: the scene's phrasings and an open vocabulary.

The phrasing LM (``pocketsphinx-vocab``) is the most accurate on requests siftom's grammar
contains, in noise too, but forces other words onto its own, often object names ("after
that i'll need the ham" -> "pass tomato oil need the ham"). The open LM
(``pocketsphinx-open``) hears those words as themselves but, in noise, lets common words
replace object names. ``pocketsphinx-dual`` decodes with both and mixes their N-best lists
as two equally trusted experts:

    log w(h) = log( 1/2 * P_closed(h) + 1/2 * P_open(h) ),  P_k(h) = softmax over list k of its scores

(a hypothesis missing from a list has probability 0 there), keeping the ``nbest`` best. The
scores are natural logs like every engine's; the channel's softmax (``asr_temperature``) then
weighs them. Measurements: docs/speech.md, "Open vocabulary".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.observation import Hypothesis
from siftom.speech.asr.base import Transcript, get_engine
from siftom.speech.asr.pocketsphinx import PocketsphinxEngine
from siftom.speech.audio import as_audio


def mix_nbest(lists: Sequence[Sequence[Hypothesis]], nbest: int) -> tuple[Hypothesis, ...]:
    """Equal-weight mixture of N-best lists, each normalised to log-probabilities over its own
    hypotheses; best first, at most ``nbest``, distinct texts (ties keep the earlier list's order)."""
    mixed: dict[str, list[float]] = {}
    used = [lst for lst in lists if lst]
    if not used:
        return ()
    log_half = -math.log(len(used))
    for lst in used:
        scores = np.array([h.score for h in lst], dtype=float)
        m = scores.max()
        z = m + math.log(float(np.exp(scores - m).sum()))
        seen: set[str] = set()
        for h in lst:
            if h.text in seen:
                continue
            seen.add(h.text)
            mixed.setdefault(h.text, []).append(log_half + h.score - z)
    out = [(t, float(np.logaddexp.reduce(v))) for t, v in mixed.items()]
    out.sort(key=lambda kv: -kv[1])  # stable: equal scores keep first-seen order
    return tuple(Hypothesis(t, s) for t, s in out[:nbest])


class DualEngine:
    """``pocketsphinx-vocab`` and ``pocketsphinx-open`` on the same audio, N-best lists mixed.

    Args:
        vocabulary: the scene's phrasings (as for ``pocketsphinx-vocab``).
        max_seconds: refuse longer audio.
        open_options: keyword arguments for the open engine (the registered ``pocketsphinx-open``).
    """

    name = "pocketsphinx-dual"

    def __init__(self, vocabulary: Sequence[str], max_seconds: float = 120.0, **open_options: Any) -> None:
        """Build both decoders (their LMs and dictionaries are cached on disk)."""
        self.max_seconds = max_seconds
        self.closed = PocketsphinxEngine(vocabulary=vocabulary, max_seconds=max_seconds)
        self.open = get_engine("pocketsphinx-open", vocabulary=vocabulary, max_seconds=max_seconds, **open_options)
        self.unknown_words = self.closed.unknown_words

    def transcribe(self, audio: np.ndarray | str | Path, nbest: int = 1) -> Transcript:
        """Decode twice and mix the N-best lists; the 1-best words come from the list that
        supplied the mixed 1-best. ``rtf`` is the sum of both decodes'."""
        x = as_audio(audio, max_seconds=self.max_seconds)
        a = self.closed.transcribe(x, nbest=nbest)
        b = self.open.transcribe(x, nbest=nbest)
        hyps = mix_nbest([a.nbest, b.nbest], nbest)
        text = hyps[0].text if hyps else ""
        words = a.words if text == a.text or text != b.text else b.words
        return Transcript(text, hyps, words, a.rtf + b.rtf, self.name, a.audio_s)
