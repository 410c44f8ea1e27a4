"""Speech recognisers behind one interface (``base.ASREngine``); engines load lazily."""

# How many ASR hypotheses every consumer asks for unless told otherwise: the library
# (``siftom.listen``, ``transcribe_for``, ``siftom demo``), the HTTP service (``asr_nbest``) and
# the evaluator (``siftom eval --nbest``). One value so the service answers as the library does;
# 10 vs 5 makes no average difference on the seed-1 dev sets (docs/speech.md, "N-best size").
DEFAULT_NBEST = 10
