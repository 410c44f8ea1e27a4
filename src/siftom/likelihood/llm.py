"""Instruction likelihood from a language model's token log-probs (paper, Methods, Instruction
Likelihood).

The paper scores "how likely the transcribed utterance corresponds to" a robot command with a
few-shot prompt of corrupted instructions and their ground-truth commands, e.g. "pass me the
silver" for ``pass(robot, human, cereal)``. Here the prompt ends with the candidate command and
the model scores the heard utterance as its continuation:

    <header>
    Command: pass(robot, human, stapler)
    Heard: could you pass me the staple her
    ...
    Command: <candidate>
    Heard:| <utterance>\\n          <- only these tokens are scored

The header and examples are a prefix shared by every candidate, so an in-process model
evaluates them once (``siftom.backends.llama_cpp``). The examples use objects no benchmark
scenario has (the paper's own example would leak the answer to its Figure 2 story).

Two prompts (``prompt=``, docs/llm.md):

* ``"sounds"`` (default): every command and every transcript is followed by its pronunciation,
  ARPAbet phonemes from CMUdict (the dictionary the phonetic likelihood uses), e.g.
  ``Command: pass(robot, human, stapler) [sounds: S T EY P L AH R]`` /
  ``Heard: could you pass me the staple her [sounds: ... S T EY P AH L / HH AH R]``. A text-only
  model does not know that "silver" sounds like "cereal", but even a 135M model copies tokens it
  has seen: the heard phonemes are likely when they repeat the command's.
* ``"plain"``: the words only, as in the paper (which relies on a model large enough to know
  how words sound).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from siftom.backends.config import LLM_BACKENDS, LLM_PROMPTS, LLMConfig
from siftom.backends.scoring import TextScorer
from siftom.errors import ObservationError, unknown_name
from siftom.likelihood.base import Scores
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phonemes import normalize_text, word_phonemes
from siftom.likelihood.phrasing import number_word
from siftom.logspace import logsumexp
from siftom.memo import Memo, memo
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

HEADER = (
    "A person asks a helper robot for objects. A speech recogniser transcribed each request, "
    "so some words are misheard. Each example gives the robot command the person meant and "
    "the noisy transcript that was heard.\n\n"
)

# (command the person meant, what the recogniser heard), corrupted as real ASR does: sound-alike
# words, numbers heard as "to"/"for"/"tree", dropped or split words, indirect phrasings.
# The objects (a workshop, an office, a garden) are deliberately ones that no built-in scenario
# uses, and no utterance contains a benchmark word, so a result on a benchmark scenario -- the
# paper's Figure 2 story in particular ("pass me the silver" for the cereal) -- is not copied from
# the prompt. tests/likelihood/test_prompt_contamination.py enforces this.
FEW_SHOT: tuple[tuple[str, str], ...] = (
    ("pass(robot, human, stapler)", "could you pass me the staple her"),
    ("deliver(robot, table, screwdrivers, 3)", "i need tree crew drivers"),
    ("pass(robot, human, towel)", "can you hand me the tower"),
    ("deliver(robot, table, candles, 2)", "we still need to handles"),
    ("pass(robot, human, scissors)", "grab the sisters please"),
    ("deliver(robot, table, notebooks, 4)", "get me for note books"),
    ("pass(robot, human, ladder)", "pass me the latter"),
    ("deliver(robot, table, hammers, 1)", "i need a hammock"),
)

PROMPTS = LLM_PROMPTS

SOUNDS_NOTE = (
    "After each command and each transcript, [sounds: ...] spells how its words are pronounced "
    "(ARPAbet phonemes, words separated by /). A misheard word sounds like the word that was "
    "meant.\n\n"
)

# Request words that carry no object, left out of the pronunciations to keep them short
# (generic English, not fitted to any benchmark; numbers and their sound-alikes stay in).
FUNCTION_WORDS = frozenset((
    "a", "an", "the", "this", "that", "these", "those", "some", "any", "more", "of", "me", "my",
    "us", "our", "it", "its", "i", "i'm", "i'd", "we", "we're", "you", "you're", "your", "can",
    "could", "would", "will", "shall", "please", "just", "and", "or", "also", "now", "too", "here",
    "there", "is", "are", "be", "need", "needs", "want", "wants", "like", "get", "give", "grab",
    "hand", "pass", "bring", "fetch", "let's", "let", "hey", "um", "uh", "okay", "oh", "so",
    "thanks", "thank",
))


def sounds(words: Sequence[str]) -> str:
    """ARPAbet pronunciation of the content words, ``/`` between words: ``S IH L V AH R``."""
    return " / ".join(" ".join(word_phonemes(w)) for w in words if w not in FUNCTION_WORDS)


def command_words(description: str) -> list[str]:
    """The words a person says for a command description: ``deliver(robot, table, forks, 3)``
    -> ``["three", "forks"]``, ``pass(robot, human, wine glass)`` -> ``["wine", "glass"]``."""
    parts = [p.strip() for p in description.split("(", 1)[-1].rstrip(")").split(",")]
    words = normalize_text(parts[2]) if len(parts) > 2 else []
    if len(parts) > 3 and parts[3].isdigit():
        words = normalize_text(number_word(int(parts[3]))) + words
    return words


def command_line(description: str, prompt: str = "sounds") -> str:
    """``Command: ...`` as the prompt writes it (with the pronunciation for ``"sounds"``)."""
    if prompt == "plain":
        return f"Command: {description}"
    return f"Command: {description} [sounds: {sounds(command_words(description))}]"


def heard_text(text: str, prompt: str = "sounds") -> str:
    """What follows ``Heard:`` (the scored target), newline-terminated."""
    words = normalize_text(text)
    said = " ".join(words) or text.strip()
    if prompt == "plain":
        return f" {said}\n"
    return f" {said} [sounds: {sounds(words)}]\n"


def describe_command(command: RobotCommand, lexicon: Lexicon | None = None) -> str:
    """The command as the prompt writes it: ``pass(robot, human, cereal)``,
    ``deliver(robot, table, forks, 3)``."""
    entry = (lexicon or default_lexicon()).entry(command.obj_class)
    if command.verb == "fetch" and command.count == 1:
        return f"pass(robot, human, {entry.singular})"
    name = entry.singular if command.count == 1 else entry.plural
    where = "human" if command.verb == "fetch" else "table"
    return f"{'pass' if command.verb == 'fetch' else 'deliver'}(robot, {where}, {name}, {command.count})"


def build_prefix(examples: Sequence[tuple[str, str]] = FEW_SHOT, header: str = HEADER,
                 prompt: str = "plain") -> str:
    """The shared part of the prompt: header and few-shot examples (``prompt``: "plain" or
    "sounds", see the module docstring)."""
    if prompt not in PROMPTS:
        raise unknown_name("LLM prompt", prompt, PROMPTS)
    if prompt == "plain":
        return header + "".join(f"Command: {c}\nHeard: {u}\n\n" for c, u in examples)
    return header + SOUNDS_NOTE + "".join(
        f"{command_line(c, prompt)}\nHeard:{heard_text(u, prompt)}\n" for c, u in examples)


_CONFIG_KEYS = ("base_url", "model", "api_key", "timeout_s", "max_retries", "cache_dir", "prompt")


def make_backend(backend: str | LLMConfig | None = None, **kwargs: object) -> TextScorer:
    """A scorer for a backend name ("llama": in-process GGUF, "openai": HTTP endpoint), an
    :class:`LLMConfig`, or None (the environment's configuration, :meth:`LLMConfig.from_env`).

    Keyword arguments override the configuration (``base_url``, ``model``, ``api_key``,
    ``timeout_s``, ``max_retries``, ``cache_dir``) or go to the backend (``model_path``,
    ``n_ctx``, ``n_threads``, ``batch_size`` ...). ``cache_dir=False`` turns the cache off.
    """
    if isinstance(backend, str) and backend not in LLM_BACKENDS:
        raise unknown_name("LLM backend", backend, LLM_BACKENDS.names())
    cfg_kw: dict[str, Any] = {k: kwargs.pop(k) for k in _CONFIG_KEYS if k in kwargs and kwargs[k] is not False}
    if "timeout" in kwargs:
        cfg_kw["timeout_s"] = kwargs.pop("timeout")
    if isinstance(backend, LLMConfig):
        config = backend.with_overrides(**cfg_kw)
    else:
        config = LLMConfig.from_env(backend=backend, **cfg_kw)
    if config.backend == "llama" and kwargs.pop("cache_dir", None) is False:
        kwargs["use_cache"] = False
    scorer: TextScorer = LLM_BACKENDS.make(config.backend, config=config, **kwargs)
    return scorer


# every LLM likelihood's scores (siftom.memo): (model id, prompt, command context, heard text) -> nats
_SCORES: Memo[float] = memo("llm.scores", 100_000)


class LLMLikelihood:
    r"""log P(phi | pi_r) from a language model prompted with corrupted-instruction examples.

    .. math::

        P(\phi \mid \pi_r) = \sum_{n \le N} w_n \, P_{LM}(h_n \mid \text{prompt}(\pi_r))^{1/\tau},
        \qquad w_n = \operatorname{softmax}_n(s_n / T_{asr})

    over the first ``nbest_limit`` hypotheses. ``tau`` (``temperature``) flattens the LM's
    sentence probabilities, which are much sharper than its calibration warrants.

    Args:
        backend: "llama", "openai", an :class:`LLMConfig`, a :class:`TextScorer` instance, or
            None (default): the configuration in ``SIFTOM_LLM_*`` (SmolLM2 in process when
            nothing is set).
        lexicon: names used to describe commands.
        examples: few-shot (command, heard) pairs; default :data:`FEW_SHOT`.
        nbest_limit: how many hypotheses to score (each costs one LM call per command).
        asr_temperature: T_asr for the N-best weights.
        temperature: tau, divides the LM log-probabilities.
        prompt: "sounds" (pronunciations in the prompt) or "plain" (words only); default: the
            configuration's (``SIFTOM_LLM_PROMPT``, else "sounds").
        **backend_kwargs: passed to the backend (``model_path``, ``base_url``, ``api_key``,
            ``model``, ``cache_dir`` ...).
    """

    name = "llm"
    needs_text = True
    needs_audio = False

    def __init__(
        self,
        backend: str | LLMConfig | TextScorer | None = None,
        *,
        lexicon: Lexicon | None = None,
        examples: Sequence[tuple[str, str]] = FEW_SHOT,
        nbest_limit: int = 3,
        asr_temperature: float = 10.0,
        temperature: float = 1.0,
        prompt: str | None = None,
        **backend_kwargs: object,
    ) -> None:
        if nbest_limit < 1:
            raise ObservationError(f"nbest_limit must be >= 1, got {nbest_limit}")
        for label, v in (("asr_temperature", asr_temperature), ("temperature", temperature)):
            if not (np.isfinite(v) and v > 0):
                raise ObservationError(f"{label} must be a positive number, got {v!r}")
        self.scorer: TextScorer = (
            make_backend(backend, **backend_kwargs)
            if backend is None or isinstance(backend, str | LLMConfig) else backend
        )
        self.lexicon = lexicon or default_lexicon()
        if prompt is None:
            prompt = (backend if isinstance(backend, LLMConfig) else LLMConfig.from_env(backend="llama")).prompt
        if prompt not in PROMPTS:
            raise unknown_name("LLM prompt", prompt, PROMPTS)
        self.prompt = prompt
        self.prefix = build_prefix(examples, prompt=prompt)
        self.nbest_limit = nbest_limit
        self.asr_temperature = float(asr_temperature)
        self.temperature = float(temperature)
        # scores memoised in siftom.memo ("llm.scores"), keyed by model, prompt, context and text

    def _score(self, items: list[tuple[str, str]]) -> np.ndarray:
        keys = [(self.scorer.model_id, self.prefix, c, t) for c, t in items]
        got = [_SCORES.peek(key) for key in keys]
        todo = [k for k, v in enumerate(got) if v is None]
        if todo:
            values = self.scorer.score(self.prefix, [items[k] for k in todo])
            for k, v in zip(todo, values, strict=True):
                got[k] = _SCORES.put(keys[k], float(v))
        return np.array(got, dtype=float)

    def log_prob(self, instruction: Instruction, commands: Sequence[RobotCommand]) -> Scores:
        """log P(phi | pi_r) for each command; shape (len(commands),)."""
        if not instruction.nbest:
            raise ObservationError(
                "the LLM likelihood needs a transcript; transcribe the audio first or use 'acoustic'"
            )
        if not commands:
            return Scores(np.zeros(0))
        hyps = instruction.nbest[: self.nbest_limit]
        scores = np.array([h.score for h in hyps]) / self.asr_temperature
        logw = scores - logsumexp(scores)
        texts = [heard_text(h.text, self.prompt) for h in hyps]
        contexts = [f"{command_line(describe_command(c, self.lexicon), self.prompt)}\nHeard:" for c in commands]
        items = [(ctx, t) for ctx in contexts for t in texts]
        lp = self._score(items).reshape(len(commands), len(texts)) / self.temperature
        return Scores(logsumexp(lp + logw[None, :], axis=1))
