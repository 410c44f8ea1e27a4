"""The option classes of every stage and door, below all of them (they import nothing above
``siftom.world.commands`` and ``siftom.settings.llm``): the model's (:class:`ModelConfig`), how a
call hears and decides (:class:`InferOptions`), the HTTP service's limits
(:class:`ServiceSettings`), the session API's (:class:`SessionLimits`) and the streaming
endpoint's (:class:`StreamLimits`).

``siftom.settings`` resolves them from a file, ``SIFTOM_*`` variables and flags; each field is a
setting (``siftom config show``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from siftom.errors import ObservationError, OptionsError, SettingsError, SiftomError
from siftom.settings.llm import LLMConfig
from siftom.world.commands import MAX_COUNT

MIN_TOKEN = 16
MAX_TOKEN = 256


def check_token(token: str, source: str = "the token") -> str:
    """``token`` without surrounding whitespace; an OptionsError naming ``source`` when it cannot be used
    (empty, shorter than :data:`MIN_TOKEN` characters, longer than :data:`MAX_TOKEN`, or not
    visible ASCII)."""
    token = token.strip()
    how = "make one with: python -c 'import secrets; print(secrets.token_urlsafe(32))'"
    if not token:
        raise OptionsError(f"{source} is empty; give a long random string, {how}")
    if len(token) < MIN_TOKEN:
        raise OptionsError(f"{source} is too short ({len(token)} characters; at least {MIN_TOKEN}, "
                           f"a short token can be guessed); {how}")
    if len(token) > MAX_TOKEN or not all(33 <= ord(ch) <= 126 for ch in token):
        raise OptionsError(f"{source} must be {MIN_TOKEN}-{MAX_TOKEN} visible ASCII characters without spaces; {how}")
    return token


@dataclass(frozen=True)
class InferOptions:
    """How :func:`siftom.infer` hears and scores an instruction.

    Attributes:
        likelihood: the instruction likelihood (``siftom plugins``: phonetic, acoustic, llm, ...);
            ``auto``: acoustic for audio when the whisper extra is installed, else phonetic.
        engine: the ASR engine for audio.
        nbest: hypotheses the recogniser keeps.
        top: hypotheses kept in the posterior's ``hypotheses``.
        decide: the decision rule every door applies when a call names none: ``teammate``
            (acts on a request it understood, asks about one it is unsure of, says why it
            declines; docs/decisions.md); ``expected-benefit``, ``ask-or-act``, and ``map``, the
            paper's rule (act on the most probable command).
    """

    likelihood: str = "auto"
    engine: str = "pocketsphinx"
    nbest: int = 10
    top: int = 10
    decide: str = "teammate"

    def __post_init__(self) -> None:
        if self.nbest < 1 or self.top < 1:
            raise SettingsError(f"infer.nbest and infer.top must be >= 1, got {self.nbest} and {self.top}")


@dataclass(frozen=True)
class SessionLimits:
    """Limits of the session API (docs/service.md; ``siftom serve --max-sessions ...``).

    Attributes:
        max_sessions: sessions stored at once (429 above; DELETE ends one, idle ones expire).
        idle_s: a session not used for this long is deleted.
        max_world_bytes: largest world in a create request (413 above). The apartment graphs of
            data/virtualhome are 160-180 kB.
        max_world_items: most objects a world may hold (422 above): inference cost grows with it.
        max_actions: most actions one session may observe (422 above).
        cache: live sessions kept in memory; the others are rebuilt from the store on use.
    """

    max_sessions: int = 1000
    idle_s: float = 24 * 3600.0
    max_world_bytes: int = 1024 * 1024
    max_world_items: int = 200
    max_actions: int = 2000
    cache: int = 256

    def __post_init__(self) -> None:
        if min(self.max_sessions, self.max_world_bytes, self.max_world_items, self.max_actions, self.cache) < 1:
            raise ObservationError("session limits must all be >= 1")
        if not self.idle_s > 0:
            raise ObservationError(f"the session idle time must be > 0 s, got {self.idle_s}")


@dataclass(frozen=True)
class StreamLimits:
    """Limits of the streaming endpoint (``siftom serve --max-streams ...``).

    Attributes:
        max_streams: streams open at once on this server (more: closed with 1013 at once).
        max_utterance_s: speech longer than this is cut and answered, and listening goes on.
        max_idle_s: a stream that sends nothing for this long is closed (4408).
        max_pending: utterances waiting for their answer while the stream goes on; one more
            closes the stream with 1013 (the client sends speech faster than it is answered).
        max_chunk_bytes: the largest binary message (1009 above); 64 KiB is 2 s of audio.
    """

    max_streams: int = 8
    max_utterance_s: float = 15.0
    max_idle_s: float = 30.0
    max_pending: int = 2
    max_chunk_bytes: int = 64 * 1024

    def __post_init__(self) -> None:
        if min(self.max_streams, self.max_pending) < 1:
            raise OptionsError("max_streams and max_pending must be >= 1")
        if not 1.0 <= self.max_utterance_s <= 120.0:
            raise OptionsError(f"max_utterance_s must be in [1, 120] s, got {self.max_utterance_s}")
        if not self.max_idle_s > 0:
            raise OptionsError(f"max_idle_s must be > 0 s, got {self.max_idle_s}")
        if not 1024 <= self.max_chunk_bytes <= 16 * 2**20:
            raise OptionsError(f"max_chunk_bytes must be in [1024, 16 MiB], got {self.max_chunk_bytes}")


# The acoustic likelihood aligns one sentence per command against the uploaded audio (~1.5 s
# for the 42-class kitchen): it serves audio requests only (a transcript request asking for it
# gets a 422 saying so).
SERVICE_LIKELIHOODS = ("phonetic", "acoustic", "llm")


def available_likelihoods(llm: LLMConfig | None = None) -> tuple[str, ...]:
    """phonetic and acoustic always; llm when an endpoint is configured (``llm`` or the
    ``SIFTOM_LLM_*`` environment) or the in-process backend (llama-cpp-python) is installed."""
    import importlib.util

    base = ("phonetic", "acoustic")
    if llm is None:
        llm, _ = service_llm_config()
    if llm is not None and llm.backend == "openai":
        return base + ("llm",)
    if (llm is not None and llm.backend == "llama") and importlib.util.find_spec("llama_cpp") is not None:
        return base + ("llm",)
    return base


def service_llm_config() -> tuple[LLMConfig | None, str]:
    """The environment's LLM configuration, or (None, why) when it is invalid."""
    try:
        return LLMConfig.from_env(), ""
    except SiftomError as exc:
        return None, str(exc)


@dataclass(frozen=True)
class ServiceSettings:
    """Limits and options of one app. Validated at construction.

    Attributes:
        max_body_bytes: largest request body (413 above). 30 s of 16 kHz 16-bit mono WAV is
            960 kB; 2 MiB leaves room for 44.1 kHz recordings of a short instruction.
        max_audio_seconds: longest recording accepted (422 above).
        request_timeout_s: a request still working after this long is answered 503.
        workers: how many requests do CPU work at once (the rest wait, within the timeout).
        audio_workers: worker processes that score audio requests in parallel (0: in the
            request thread, one recording per scene at a time; service/audio_pool.py).
        likelihoods: instruction likelihoods offered (a subset of SERVICE_LIKELIHOODS; default:
            those whose backend is installed or configured).
        llm: the language model of the "llm" likelihood (default: ``SIFTOM_LLM_*``, see
            docs/llm.md; an invalid environment leaves it None and ``/healthz`` says why).
        cache_size: cached OnlineInference objects (one per scenario, prefix, mode, likelihood).
        plan_max_time: seconds of A* for the robot's plan before the greedy fallback.
        sessions: limits of the session API (sessions, world size, idle time; SessionLimits).
        stream: limits of the streaming endpoint (streams, utterance length, idle time; StreamLimits).
        token: the token every request must carry (``Authorization: Bearer``, ``?token=`` or the
            cookie it sets; docs/security.md); None: none asked for (``siftom serve`` makes one
            when it listens beyond loopback). Never shown (``siftom config show`` masks it).
        allowed_hosts: ``Host`` names answered beyond loopback names and IP addresses (400 for
            others: DNS rebinding); ``*``: any (a proxy in front checks them).
        allowed_origins: ``Origin`` values (``scheme://host[:port]``) whose pages may post and
            stream, beyond the server's own (403 for others); ``*``: any.
    """

    max_body_bytes: int = 2 * 1024 * 1024
    max_audio_seconds: float = 30.0
    request_timeout_s: float = 20.0
    workers: int = 4
    audio_workers: int = 0
    likelihoods: tuple[str, ...] | None = None
    cache_size: int = 256
    plan_max_time: float = 0.3
    llm: LLMConfig | None = None
    llm_error: str = ""
    sessions: SessionLimits = field(default_factory=lambda: SessionLimits())
    stream: StreamLimits = field(default_factory=lambda: StreamLimits())
    token: str | None = field(default=None, repr=False)
    allowed_hosts: tuple[str, ...] = ()
    allowed_origins: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.token is not None:
            object.__setattr__(self, "token", check_token(self.token, "service.token"))
        if self.llm is None and not self.llm_error:
            cfg, why = service_llm_config()
            object.__setattr__(self, "llm", cfg)
            object.__setattr__(self, "llm_error", why)
        if self.likelihoods is None:
            object.__setattr__(self, "likelihoods", available_likelihoods(self.llm) if self.llm is not None
                               else ("phonetic", "acoustic"))
        if self.max_body_bytes < 1024:
            raise ObservationError(f"max_body_bytes must be >= 1024, got {self.max_body_bytes}")
        if not 0 < self.max_audio_seconds <= 600:
            raise ObservationError(f"max_audio_seconds must be in (0, 600], got {self.max_audio_seconds}")
        if not self.request_timeout_s > 0:
            raise ObservationError(f"request_timeout_s must be > 0, got {self.request_timeout_s}")
        if self.workers < 1 or self.cache_size < 1:
            raise ObservationError("workers and cache_size must be >= 1")
        if not 0 <= self.audio_workers <= 64:
            raise ObservationError(f"audio_workers must be in [0, 64], got {self.audio_workers}")
        bad = [lk for lk in self.offered if lk not in SERVICE_LIKELIHOODS]
        if bad or not self.likelihoods:
            raise ObservationError(f"likelihoods must be a non-empty subset of {SERVICE_LIKELIHOODS}, got {bad}")

    @property
    def offered(self) -> tuple[str, ...]:
        """The likelihoods offered (``likelihoods`` once resolved at construction)."""
        return self.likelihoods or ()


MODES = ("full", "speech-only", "action-only")


@dataclass(frozen=True)
class ModelConfig:
    """Options of the SIFToM model. Validated at construction."""

    mode: str = "full"
    betas: tuple[float, ...] = (0.5, 1.0, 2.0, 4.0)
    epsilon: float = 0.01
    unknown_prior: float = 0.02
    help_kappa: float = 0.1
    speech_weight: float = 1.0
    max_count: int = MAX_COUNT
    off_plan: float = 0.005

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ObservationError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if not self.betas or any(not (b > 0 and math.isfinite(b)) for b in self.betas):
            raise ObservationError(f"betas must be positive finite numbers, got {self.betas}")
        if not 0 <= self.unknown_prior < 1:
            raise ObservationError(f"unknown_prior must be in [0, 1), got {self.unknown_prior}")
        if self.speech_weight < 0 or self.help_kappa < 0:
            raise ObservationError("speech_weight and help_kappa must be >= 0")
        if not 0 <= self.off_plan < 1:
            raise ObservationError(f"off_plan must be in [0, 1), got {self.off_plan}")

    @property
    def uses_actions(self) -> bool:
        return self.mode != "speech-only"

    @property
    def uses_speech(self) -> bool:
        return self.mode != "action-only"
