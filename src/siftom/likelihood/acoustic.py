"""Acoustic instruction likelihood: score the audio itself against each command's key phrase.

**With the whisper extra installed (the default then):**

    log P(a | pi_r) = pool[ log P_phonetic(N-best | pi_r), w(pi_r) / T_w ]   (a product; ``likelihood.pooling``)

where w is the Whisper factor (``siftom.likelihood.whisper_factor``): the log-probability
Whisper tiny.en gives the heard words with each command's key phrase in place of the heard
object words, by teacher forcing -- an acoustic model independent of pocketsphinx, whose
N-best the first term scores. T_w = 3 nats (docs/likelihoods.md: chosen on the seed-1 kitchen
set). The pocketsphinx key-phrase alignment below is then off (``align=None``; ``align=True``
adds it back): on the seed-1 set it added nothing on top of Whisper and cost most of the time.

**Without Whisper (or ``whisper=False``),** for robot command pi_r with key phrases k (its content words: "cereal", "three forks", "the
cutlery" -> "cutlery"; ``phrasing.content_prior``) and audio a,

    log P(a | pi_r) = logsumexp_k [ s(a_W, k) / T + log P(k | pi_r) ]  +  log P_phonetic(N-best | pi_r)

(the last term only with ``with_phonetic``, the default: the alignment and the recogniser's
N-best are two views of one recording, and alone the alignment is the weaker one; see
docs/likelihoods.md for the measurements),

where a_W is the audio from the word before the object to the word after it (as the
recogniser placed them), and s is the pocketsphinx forced-alignment score, in nats (siftom.speech.acoustic), of
the words heard there with the heard object words (the 1-best words that belong to any
command's key phrase) replaced by k: "can you pass me the serial please" is scored for
cereal as "the cereal please" against the audio of "the serial please". Every candidate explains the
same frames with the same free words around its key phrase, so the scores compare, and the
carrier, whatever words it has, is not a template from the phrasing grammar. When the 1-best
holds no key word the scorer falls back to aligning each command's whole phrasing closest to
what was heard (``sentence`` mode). T is a temperature in nats that turns alignment
scores, which are over-confident, into a likelihood (paper, Methods, Instruction Likelihood);
docs/likelihoods.md gives the calibration.

**Pruning** (``prune=True``) aligns only the commands the N-best times the context makes likely
(``prune_mass``, ``max_candidates``, ``top_nbest``); every other command gets the lowest aligned
value less how much less likely the N-best makes it. **Whisper's share** (``whisper_candidates``)
scores with Whisper the pruned commands of at most K objects (``whisper_factor.whisper_share``).
docs/likelihoods.md gives both rules and their measurements.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.concurrency import make_once as _once
from siftom.errors import ObservationError, SiftomError
from siftom.likelihood.alignscores import FAILED as FAILED
from siftom.likelihood.alignscores import RawScores as RawScores
from siftom.likelihood.alignscores import align_phrasings, combine_scores
from siftom.likelihood.alignscores import temperature_for_snr as temperature_for_snr
from siftom.likelihood.base import Scores, as_scores
from siftom.likelihood.keyphrases import (  # re-exported: the acoustic likelihood's words
    closest_phrasing as closest_phrasing,
)
from siftom.likelihood.keyphrases import (
    heard_frame as heard_frame,
)
from siftom.likelihood.keyphrases import (
    key_phrases as key_phrases,
)
from siftom.likelihood.keyphrases import (
    key_word_forms as key_word_forms,
)
from siftom.likelihood.keyphrases import (
    names as names,
)
from siftom.likelihood.keyphrases import (
    top_phrasings as top_phrasings,
)
from siftom.likelihood.pooling import DEFAULT_POOL, POOLS, whisper_slot_factor
from siftom.logspace import logsumexp
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

if TYPE_CHECKING:
    from siftom.likelihood.lexicon import Lexicon
    from siftom.speech.acoustic import ForcedAligner

Phrasings = Callable[[RobotCommand], Sequence[tuple[str, float]]]
# calibrated on a dataset built with another seed than the benchmark (docs/likelihoods.md)
DEFAULT_TEMPERATURE = 75.0
# T grows by exp(kappa * gap) when alignments fit worse than free phones (docs/likelihoods.md); chosen on seed-1 sets
DEFAULT_GAP_SCALE = 4.0
# the Whisper factor (likelihood/whisper_factor.py): w / T_w, chosen on the seed-1 kitchen set (docs/likelihoods.md)
DEFAULT_WHISPER_TEMPERATURE = 3.0
DEFAULT_WHISPER_PAD_S = 3.0
DEFAULT_WHISPER_PRIOR = 0.0  # lambda of the content-free debiasing: no gain on dev or test sets (docs/likelihoods.md)
# the commands of at most this many objects get Whisper's teacher-forced score (those Whisper heard named,
# then the best by N-best x context); chosen on a seed-5 kitchen set, checked on held-out sets (docs/likelihoods.md)
DEFAULT_WHISPER_CANDIDATES = 4


class AcousticLikelihood:
    """log P(audio | robot command) by forced alignment of key phrases (see module doc).

    Args:
        phrasings: for ``mode="sentence"``: maps a command to (text, log prior) pairs
            (default :func:`top_phrasings`, or the phrasing closest to the 1-best when an N-best
            list is known).
        temperature: T in nats; must be > 0.
        aligner: a ForcedAligner to share (one is created lazily otherwise).
        with_phonetic: multiply in the N-best phonetic likelihood (default; two views of one
            recording: what the recogniser's N-best says and how well each key phrase fits the
            audio). A pruned command then gets the worst aligned score plus its own phonetic term.
        mode: ``"key"`` (key phrase in the recogniser's object window; sentence fallback) or
            ``"sentence"`` (whole phrasings over the whole audio).
        prune: align only the commands that matter (module doc); needs an N-best list.
        prune_mass, max_candidates, top_nbest: the pruning rule.
        gap_scale: kappa in T * exp(kappa * max(gap, 0)), where gap is how many nats per frame
            the best aligned key phrase scores below a free phone loop over the same audio
            (``siftom.speech.phoneloop``); 0 turns the phone loop off (one fewer decode).
        whisper: add the Whisper factor w / T_w (module doc); None (default): when the whisper
            extra is installed; True without it raises BackendUnavailableError (install siftom[whisper]).
        align: pocketsphinx key-phrase alignment; None (default): only without the Whisper factor.
        whisper_temperature: T_w in nats (> 0).
        whisper_pad_s: Whisper's feature window, at least this many seconds (``WhisperScorer``).
        whisper_prior: lambda >= 0, content-free debiasing: each text scores log P(text | audio)
            - lambda * log P(text | digital silence) (``WhisperFactor``); 0 scores as without it.
        whisper_listen: also let Whisper transcribe the clip (greedy, on the encoding the factor
            computes anyway) and use its words as a second carrier; the commands it names join the
            pruned set (``WhisperFactor``).
        pool: how the N-best and the Whisper factor meet: ``"product"`` (default), ``"mixture"`` (a
            linear pool, flat where they disagree: fewer confident wrong answers, more questions) or
            ``"tempered"`` (``likelihood.pooling``; docs/likelihoods.md).
        whisper_slot_confidence: weigh Whisper's transcript in the slot channel by its own confidence
            (default); False reads it at full weight (``likelihood.pooling``).
        whisper_candidates: the pruned commands of at most this many objects get the Whisper factor
            (module doc, "Whisper's share"); default ``DEFAULT_WHISPER_CANDIDATES``.
        whisper_model: the Whisper model (a CTranslate2 folder) that scores and transcribes;
            default: the ``whisper_model`` setting (``$SIFTOM_WHISPER_MODEL``), else the packaged tiny.en.
        tie_counts: when no count word was heard, no count of a class is favoured over another
            (``likelihood.counts``).
        lexicon: how the classes are named (default: the built-in lexicon; a world's own names
            come through :func:`siftom.likelihood.lexicon.lexicon_for`).
    """

    uses_context = True  # SIFToM passes the action term and prior per command as ``context``

    def __init__(
        self,
        phrasings: Phrasings | None = None,
        temperature: float = DEFAULT_TEMPERATURE,
        aligner: object | None = None,
        name: str = "acoustic",
        mode: str = "key",
        with_phonetic: bool = True,
        prune: bool = True,
        prune_mass: float = 0.995,
        max_candidates: int = 6,
        top_nbest: int = 3,
        gap_scale: float = DEFAULT_GAP_SCALE,
        whisper: bool | None = None,
        align: bool | None = None,
        whisper_temperature: float = DEFAULT_WHISPER_TEMPERATURE,
        whisper_pad_s: float = DEFAULT_WHISPER_PAD_S,
        whisper_prior: float = DEFAULT_WHISPER_PRIOR,
        whisper_listen: bool = True,
        whisper_model: str | Path | None = None,
        tie_counts: bool = True,
        whisper_prompt: bool = True,
        lexicon: Lexicon | None = None,
        pool: str = DEFAULT_POOL,
        whisper_slot_confidence: bool = True,
        whisper_candidates: int | None = None,
    ) -> None:
        """Validate the options; the aligner loads on first use."""
        if not np.isfinite(temperature) or temperature <= 0:
            raise SiftomError(f"temperature must be a positive number of nats, got {temperature}")
        if mode not in ("key", "sentence"):
            raise SiftomError(f"mode must be 'key' or 'sentence', got {mode!r}")
        if not np.isfinite(gap_scale) or gap_scale < 0:
            raise SiftomError(f"gap_scale must be a number >= 0, got {gap_scale}")
        if not 0 < prune_mass <= 1 or max_candidates < 1 or top_nbest < 0:
            raise SiftomError("prune_mass must be in (0, 1], max_candidates >= 1 and top_nbest >= 0")
        wc = DEFAULT_WHISPER_CANDIDATES if whisper_candidates is None else whisper_candidates
        if wc < 1:
            raise SiftomError(f"whisper_candidates must be at least 1, got {whisper_candidates}")
        self.whisper_candidates = int(wc)
        if pool not in POOLS:
            raise SiftomError(f"pool must be one of {', '.join(POOLS)}, got {pool!r}")
        self.pool, self.whisper_slot_confidence = pool, bool(whisper_slot_confidence)
        self.phrasings = phrasings
        self.temperature = float(temperature)
        self.name = name
        self.mode = mode
        self.with_phonetic = with_phonetic
        self.prune = prune
        self.prune_mass, self.max_candidates, self.top_nbest = prune_mass, max_candidates, top_nbest
        self.gap_scale = float(gap_scale)
        if not np.isfinite(whisper_temperature) or whisper_temperature <= 0:
            raise SiftomError(f"whisper_temperature must be a positive number of nats, got {whisper_temperature}")
        if not np.isfinite(whisper_prior) or whisper_prior < 0:
            raise SiftomError(f"whisper_prior must be a number >= 0, got {whisper_prior}")
        from siftom.likelihood.whisper_factor import WhisperFactor, whisper_available

        if whisper and not whisper_available():
            from siftom.errors import missing_extra

            raise missing_extra("whisper", "faster-whisper")
        self.uses_whisper = whisper_available() if whisper is None else bool(whisper)
        self.whisper_temperature = float(whisper_temperature)
        self.whisper_prior = float(whisper_prior)  # lambda of the content-free debiasing (WhisperFactor)
        # pocketsphinx alignment only when asked or when there is no Whisper factor to replace it
        self.aligns = (not self.uses_whisper) if align is None else bool(align)
        if not self.aligns and not self.uses_whisper:
            raise SiftomError("align=False needs the Whisper factor (whisper=True and the whisper extra): "
                              "with neither there is no acoustic term; keep align=True")
        if whisper_model is not None:
            from siftom.speech.asr.whisper import whisper_model_dir

            whisper_model = str(whisper_model_dir(whisper_model))  # a wrong folder fails now, not at the first clip
        self.whisper_model = whisper_model
        self.tie_counts = bool(tie_counts)
        self._whisper = (WhisperFactor(whisper_pad_s, whisper_prior, listen=whisper_listen, model_dir=whisper_model,
                                       prompt=whisper_prompt, lexicon=lexicon)
                         if self.uses_whisper else None)
        self.lexicon = lexicon
        self._aligner: Any = aligner  # a ForcedAligner (or a stand-in with its methods)
        self._loop: Any = None
        self._phonetic: Any = None

    def _top_phrasings(self, command: RobotCommand) -> list[tuple[str, float]]:
        return top_phrasings(command, lexicon=self.lexicon)

    @property
    def aligner(self) -> ForcedAligner:
        """The shared ForcedAligner."""
        if self._aligner is None:
            from siftom.speech.acoustic import ForcedAligner

            _once(self, "_aligner", ForcedAligner)
        aligner: ForcedAligner = self._aligner
        return aligner

    def _phonetic_lp(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> np.ndarray:
        if self._phonetic is None:
            from siftom.likelihood.phonetic import PhoneticLikelihood

            _once(self, "_phonetic", lambda: PhoneticLikelihood(self.lexicon))
        words = Instruction(nbest=instruction.nbest, focus=instruction.focus, scene_words=instruction.scene_words)
        return np.array(as_scores(self._phonetic.log_prob(words, commands)).log_probs)

    def candidates(self, instruction: Instruction, commands: Sequence[RobotCommand],
                   context: np.ndarray | None = None, phon: np.ndarray | None = None) -> np.ndarray:
        """Indices of the commands to align (all of them unless pruning applies)."""
        n = len(commands)
        if not self.prune or not instruction.nbest or n <= self.max_candidates:
            return np.arange(n)
        if phon is None:
            phon = self._phonetic_lp(instruction, commands)
        q = phon + (np.asarray(context, dtype=float) if context is not None else 0.0)
        p = np.exp(q - logsumexp(q))
        order = np.argsort(-p, kind="stable")
        upto = int(np.searchsorted(np.cumsum(p[order]), self.prune_mass) + 1)
        keep = set(order[: min(upto, self.max_candidates)].tolist())
        keep.update(np.argsort(-phon, kind="stable")[: self.top_nbest].tolist())
        return np.array(sorted(keep))

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand],
                 context: np.ndarray | None = None) -> Scores:
        """Return log P(audio | command) for each command, shape (len(commands),), and the evidence.

        ``context``: optional log P(command | actions) up to a constant (used for pruning only).
        When neither the recogniser's 1-best nor Whisper's transcript holds a count word, every
        plural count of a class gets the same value (``likelihood.counts``; ``tie_counts=False``
        turns it off).
        """
        raw = self.raw_scores(instruction, commands, context)
        out = self.combine(raw, len(commands))
        evidence = dict(raw.evidence)
        if self.tie_counts and len(commands):
            from siftom.likelihood.counts import count_heard, tie_unheard_counts

            heard = [instruction.text] if instruction.nbest else []
            if evidence.get("whisper_heard"):
                heard.append(str(evidence["whisper_heard"]))
            evidence["count_heard"] = count_heard(heard)
            if not evidence["count_heard"]:
                out = tie_unheard_counts(out, commands)
        whisper = str(evidence.get("whisper_heard") or "")
        if whisper.strip() and len(commands):
            # Whisper writes what it heard in an open vocabulary: the target slot of its words is
            # read by the slot channel as a transcript's is, weighed by Whisper's confidence (pooling)
            out = out + whisper_slot_factor(whisper, evidence.get("whisper_logprob"), commands, self.lexicon,
                                            instruction.focus, self.whisper_slot_confidence)
        return Scores(out, evidence)

    def combine(self, raw: RawScores, n: int, temperature: float | None = None) -> np.ndarray:
        """Turn raw alignment scores into log-likelihoods at temperature T (default: the likelihood's)."""
        return combine_scores(raw, n, self.temperature if temperature is None else temperature, self.gap_scale,
                              self.with_phonetic, self.whisper_temperature, self.pool)

    def raw_scores(self, instruction: Instruction, commands: Sequence[RobotCommand],
                   context: np.ndarray | None = None) -> RawScores:
        """Align the kept commands' key phrases (or sentences): scores in nats before T."""
        if not instruction.has_audio:
            raise ObservationError(
                "the acoustic likelihood needs the audio: send the recording (multipart field audio, --audio FILE "
                "or Instruction(audio=PATH)), or use a transcript-based likelihood such as phonetic"
            )
        if not commands:
            return RawScores(np.zeros(0, dtype=int), (), "none")
        from siftom.speech.audio import as_audio

        x = instruction.samples if instruction.samples is not None else as_audio(instruction.audio)  # type: ignore[arg-type]
        phon = self._phonetic_lp(instruction, commands) if instruction.nbest and (
            self.with_phonetic or self.prune) else None
        keep = self.candidates(instruction, commands, context, phon)
        # while Whisper transcribes, the commands it will most likely score are scored in the 1-best's carrier
        prepared = (self._whisper.listen(x, commands, instruction, self.whisper_share(keep, [], phon, context, commands))
                    if self._whisper is not None and instruction.nbest else None)
        named: list[int] = []
        if prepared is not None and prepared[1]:
            # a command whose key phrase Whisper heard is scored even when the N-best and the actions
            # alone would have pruned it
            named = [i for i, c in enumerate(commands) if names(prepared[1], (k for k, _ in key_phrases(c, lexicon=self.lexicon)))]
            keep = np.array(sorted(set(keep.tolist()) | set(named)))
        wkeep = self.whisper_share(keep, named, phon, context, commands)
        kept = [commands[i] for i in keep]
        aligned = 0
        items: list[list[tuple[float, float]]] = []
        if not self.aligns:
            mode, seg = "whisper", x
        else:
            frame = None
            if self.mode == "key" and instruction.words:
                key_words = key_word_forms(k for c in kept for k, _ in key_phrases(c, lexicon=self.lexicon))
                frame = heard_frame(instruction.words, key_words)
            if frame is not None:
                start, end, before, after = frame
                seg = x[int(start * 16000):] if end is None else x[int(start * 16000):int(end * 16000)]
                items, aligned = align_phrasings(self.aligner,
                    seg, kept, lambda c: [(" ".join([*before, k, *after]), lp) for k, lp in key_phrases(c, lexicon=self.lexicon)])
                mode = "key"
            else:
                seg = x
                heard = instruction.text if instruction.nbest else None
                if heard is not None and self.phrasings is None:
                    items, aligned = align_phrasings(self.aligner, x, kept, lambda c: [closest_phrasing(c, heard, self.lexicon)])
                else:
                    items, aligned = align_phrasings(self.aligner, x, kept, self.phrasings or self._top_phrasings)
                mode = "sentence"
        wh = (self._whisper.scores(instruction, commands, wkeep, x, prepared)
              if self._whisper is not None and prepared is not None else None)
        if wh is not None and not self.aligns:
            mode = f"whisper-{wh.mode}"  # "whisper-key" or "whisper-sentence"
        if not items and wh is None:  # no N-best (the Whisper factor needs the heard words): align phrasings
            (items, aligned), mode = align_phrasings(self.aligner, x, kept, self.phrasings or self._top_phrasings), "sentence"
        # what this call used besides the N-best: its mode and, with the Whisper factor, Whisper's words
        evidence: dict[str, Any] = {"acoustic_mode": mode, "commands_scored": len(kept), "phrases_aligned": aligned}
        if self._whisper is not None and self._whisper.listens:
            evidence["whisper_heard"] = " ".join(wh.heard) if wh is not None else ""
            evidence["whisper_use"] = wh.use if wh is not None else "none"  # "carrier", "guesses" or "none"
            if wh is not None and wh.heard:
                evidence["whisper_logprob"] = round(wh.logprob, 4)
        if wh is not None:
            evidence["whisper_commands"], evidence["whisper_texts"] = len(wkeep), wh.texts
        return RawScores(keep, tuple(items), mode, phon, self._gap(seg, items) if items else None,
                         wh.values if wh is not None else None, evidence, wkeep if wh is not None else None)

    def whisper_share(self, keep: np.ndarray, named: Sequence[int], phon: np.ndarray | None,
                      context: np.ndarray | None, commands: Sequence[RobotCommand] | None = None) -> np.ndarray:
        """The kept commands that get the Whisper factor (``whisper_factor.whisper_share``)."""
        from siftom.likelihood.whisper_factor import whisper_share

        return whisper_share(keep, named, phon, context, self.whisper_candidates, commands)

    def _gap(self, seg: np.ndarray, items: Sequence[Sequence[tuple[float, float]]]) -> float | None:
        """(phone-loop score - best alignment score) per 10 ms frame over the aligned audio."""
        ok = [sc for it in items for sc, _ in it if sc > FAILED]
        if self.gap_scale == 0 or not ok or len(seg) < 1600:
            return None
        if self._loop is None:
            from siftom.speech.phoneloop import PhoneLoop

            _once(self, "_loop", PhoneLoop)
        loop = self._loop.score(seg)
        return None if not np.isfinite(loop) else (loop - max(ok)) / (len(seg) / 160)

    def log_prob_audio(self, audio: np.ndarray | str | Path, commands: Sequence[RobotCommand],
                       heard: str | None = None) -> Scores:
        """Whole-sentence log-likelihoods for raw 16 kHz samples or a path, every command aligned
        (with ``heard``, an ASR 1-best, in its phrasing closest in words to what was heard)."""
        if not commands:
            return Scores(np.zeros(0))
        from siftom.speech.audio import as_audio

        x = as_audio(audio)
        if heard is not None and self.phrasings is None:
            items, aligned = align_phrasings(self.aligner, x, commands, lambda c: [closest_phrasing(c, heard, self.lexicon)])
        else:
            items, aligned = align_phrasings(self.aligner, x, commands, self.phrasings or self._top_phrasings)
        raw = RawScores(np.arange(len(commands)), tuple(items), "sentence")
        return Scores(self.combine(raw, len(commands)),
                      {"acoustic_mode": "sentence", "commands_scored": len(commands), "phrases_aligned": aligned})
