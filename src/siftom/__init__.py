"""siftom: follow noisy spoken instructions pragmatically (SIFToM).

Bayesian inverse planning over a symbolic scene combined with instruction likelihoods
computed from what was heard (transcripts, N-best lists or the audio itself).
From a recording to the posterior in one call: ``siftom.api.listen(audio, scenario=...)``.
"""

__version__ = "0.1.0"
