"""The service's working parts, safe to call from many threads at once.

* Inference: one model per (mode, likelihood), shared by every thread (a likelihood keeps
  nothing from one call to the next; its memo caches guard themselves). The expensive action
  term is cached:
  an ``OnlineInference`` that has observed a scenario's first n actions is kept per
  (scenario, n, mode, likelihood), so a request only scores what was heard (~2 ms).
* ASR: one pocketsphinx decoder per scenario vocabulary, each behind a lock (a decoder holds
  one utterance at a time, and holds the GIL while it decodes); with ``audio_workers`` > 0,
  audio requests run in worker processes instead, several at once (service/audio_pool.py).
* Maps: matplotlib's pyplot is not thread-safe; rendering is serialised and PNGs are cached
  in the service's own folder under names it makes (a hash), never a client's string.
"""

from __future__ import annotations

import hashlib
import io
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from siftom.api import get_model
from siftom.assist.clarify import ClarifyPolicy, clarify
from siftom.assist.route import RobotPlan, robot_plan
from siftom.backends.config import LLMConfig
from siftom.errors import AudioError, ObservationError, SiftomError, unknown_name
from siftom.inference.listen import Cache
from siftom.inference.model import OnlineInference, Posterior
from siftom.observation import Instruction
from siftom.scenarios.base import Scenario, get_scenario, scenario_ids
from siftom.service.sessions import SessionLimits
from siftom.service.stream_settings import StreamLimits
from siftom.world.model import AGENT_NAMES, HELD, NOTHING

T = TypeVar("T")

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

    def __post_init__(self) -> None:
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


@dataclass
class _Engine:
    engine: Any
    lock: threading.Lock = field(default_factory=threading.Lock)


def scenario_vocabulary(scenario: Scenario) -> list[str]:
    """Every phrasing of every command of the scenario: the ASR's language model."""
    from siftom.api import vocabulary_for

    return sorted(vocabulary_for(scenario.world, scenario.verb))


def timeline(scenario: Scenario) -> list[dict[str, Any]]:
    """Per observed step: the action that led there, where each agent is, what is where."""
    w = scenario.world
    out = []
    for t, s in enumerate(scenario.states()):
        items: dict[str, list[str]] = {}
        for i, loc in enumerate(s.item_at):
            if loc != HELD:
                items.setdefault(w.places[loc].name, []).append(w.items[i].name)
        out.append({
            "t": t,
            "action": w.format_action(scenario.actions[t - 1]) if t else None,
            "agents": {AGENT_NAMES[k]: w.places[p].name for k, p in enumerate(s.agent_at)},
            "held": {AGENT_NAMES[k]: (w.items[h].name if h != NOTHING else None) for k, h in enumerate(s.held)},
            "open": [p.name for i, p in enumerate(w.places) if p.closable and s.is_open(i)],
            "items": items,
        })
    return out


class Runtime:
    """Caches and locks shared by the request handlers (see module doc)."""

    def __init__(self, settings: ServiceSettings, data_dir: Path) -> None:
        self.settings = settings
        self.data_dir = data_dir
        self.map_dir = data_dir / "maps"
        self.map_dir.mkdir(parents=True, exist_ok=True)
        self.started = time.time()
        self._online = Cache(settings.cache_size)
        self._plans = Cache(1024)
        self._engines = Cache(8)
        self._render_lock = threading.Lock()
        self.requests = 0
        self.audio_pool: Any = None
        if settings.audio_workers > 0:
            from siftom.service.audio_pool import AudioPool

            self.audio_pool = AudioPool(settings)
        self._warm = threading.Thread(target=self._load_default_audio_model, daemon=True)
        self._warm.start()

    def close(self) -> None:
        """Stop the audio worker processes, if any."""
        if self.audio_pool is not None:
            self.audio_pool.close()

    def _load_default_audio_model(self) -> None:
        """Load the acoustic model (Whisper) in the background, so the first recording, which gets it
        by default, does not wait for the model to load."""
        from siftom.likelihood.registry import resolve_likelihood

        if "acoustic" not in self.settings.offered or resolve_likelihood(None, True)[0] != "acoustic":
            return
        try:
            lk = get_model("full", "acoustic").likelihood
            whisper = getattr(lk, "_whisper", None)
            if whisper is not None:  # load the model and run it once (its first pass is the slowest)
                import numpy as np

                whisper.scorer.score(np.zeros(16_000, dtype=np.float32), ["bring me the cup"])
        except SiftomError:  # reported by the first request that needs it
            pass

    # ----- scenarios ---------------------------------------------------------------------
    @staticmethod
    def scenario(scenario_id: str) -> Scenario:
        """A registered scenario; the id is only ever a registry key."""
        return get_scenario(scenario_id)

    @staticmethod
    def scenario_ids() -> list[str]:
        return scenario_ids()

    def llm_status(self) -> dict[str, Any]:
        """What /healthz says about the language model (never the API key)."""
        cfg = self.settings.llm
        out: dict[str, Any] = {"offered": "llm" in (self.settings.likelihoods or ())}
        if cfg is not None:
            out.update(cfg.public())
            out["summary"] = cfg.describe()
        if self.settings.llm_error:
            out["error"] = self.settings.llm_error
        return out

    def resolve_likelihood(self, name: str, instruction: Instruction | None) -> tuple[str, str]:
        """(likelihood to run, why): "auto" is acoustic for a recording when this server offers it and
        the whisper extra is installed, else phonetic (``siftom.likelihood.registry.resolve_likelihood``)."""
        from siftom.likelihood.registry import AUTO, resolve_likelihood

        if name != AUTO:
            self.check_likelihood(name)
            return name, "asked for"
        has_audio = instruction is not None and instruction.has_audio and "acoustic" in self.settings.offered
        return resolve_likelihood(None, has_audio)

    def check_likelihood(self, name: str) -> None:
        from siftom.likelihood.registry import AUTO

        if name == AUTO:
            return
        if name not in self.settings.offered:
            # a request field, not a path: 422 (ObservationError), with the valid names
            raise ObservationError(str(unknown_name("instruction likelihood on this server", name,
                                                    self.settings.offered)))

    # ----- inference ---------------------------------------------------------------------
    def _online_for(self, sid: str, n: int, mode: str, likelihood: str) -> OnlineInference:
        sc = self.scenario(sid)

        def make() -> OnlineInference:
            model = get_model(mode, likelihood, self.settings.llm)
            on = model.online(sc.world, sc.start, sc.goals, sc.verb)
            for a in sc.actions[:n]:
                on.observe(a)
            return on

        return self._online.get_or_create((sid, n, mode, likelihood), make)

    def posterior(self, sid: str, instruction: Instruction | None, mode: str, likelihood: str,
                  n_actions: int | None = None, actions: list[str] | None = None, top: int = 10) -> Posterior:
        """Run inference (thread-safe); recorded actions use the cached action term."""
        self.check_likelihood(likelihood)
        sc = self.scenario(sid)
        if actions is not None:
            from siftom.api import infer_actions

            return infer_actions(sid, actions, instruction, mode, likelihood, self.settings.llm)
        n = len(sc.actions) if n_actions is None else n_actions
        if not 0 <= n <= len(sc.actions):
            raise ObservationError(f"n_actions must be between 0 and {len(sc.actions)} for {sid}")
        return self._online_for(sid, n, mode, likelihood).posterior(instruction, top=top)

    def plan(self, sid: str, n_actions: int | None, actions: list[str] | None, command: str) -> RobotPlan | None:
        """The robot's plan for ``command`` from the state when the human spoke (cached)."""
        if actions is not None:
            return None  # a custom action sequence: no cached state to plan from
        sc = self.scenario(sid)
        n = len(sc.actions) if n_actions is None else n_actions
        state = sc.states()[n]
        try:
            cmd = sc.parse_command(command)
        except Exception:  # the MAP command is always the scenario's; be safe anyway
            return None
        return self._plans.get_or_create(
            (sid, n, str(cmd)), lambda: robot_plan(sc, state, cmd, max_time=self.settings.plan_max_time))

    def infer(self, sid: str, instruction: Instruction | None, mode: str, likelihood: str,
              n_actions: int | None, actions: list[str] | None, top: int, policy: ClarifyPolicy,
              decide: str = "map") -> dict[str, Any]:
        """The response body of ``POST /v1/infer``."""
        from siftom.inference.listen import with_likelihood

        likelihood, why = self.resolve_likelihood(likelihood, instruction)
        post = self.posterior(sid, instruction, mode, likelihood, n_actions, actions, top)
        if instruction is not None:
            post = with_likelihood(post, likelihood, why)
        body: dict[str, Any] = {"scenario": sid, **post.to_json(top=top)}
        body["nbest"] = [{"text": h.text, "score": h.score} for h in (instruction.nbest if instruction else ())]
        body["clarification"] = clarify(post.commands, policy).to_json()
        if post.joint is not None and post.joint.state is not None:
            from siftom.assist.decide import Situation, get_rule

            sc = self.scenario(sid)
            body["decision"] = get_rule(decide)(post, Situation(sc.world, post.joint.state, sc.target)).to_json()
        plan = self.plan(sid, n_actions, actions, post.command)
        body["plan"] = plan.to_json() if plan is not None else None
        return body

    # ----- audio -------------------------------------------------------------------------
    def decode_audio(self, data: bytes) -> np.ndarray:
        """Decode an uploaded recording in memory (no file is written) to 16 kHz mono."""
        import soundfile as sf

        from siftom.speech.audio import to_mono16k

        if not data:
            raise AudioError("the audio file is empty; record the instruction again")
        limit = self.settings.max_audio_seconds
        try:
            with sf.SoundFile(io.BytesIO(data)) as f:
                if f.frames <= 0 or f.samplerate <= 0:
                    raise AudioError("the audio contains no samples; record the instruction again")
                seconds = f.frames / f.samplerate
                if seconds > limit:
                    raise AudioError(f"the recording lasts {seconds:.1f} s, more than the {limit:g} s allowed; "
                                     "record only the instruction")
                x = f.read(dtype="float32", always_2d=True)
                rate = f.samplerate
        except AudioError:
            raise
        except Exception as exc:  # libsndfile raises several types for unreadable data
            raise AudioError(f"cannot read the upload as audio ({type(exc).__name__}); send WAV, FLAC or OGG, "
                             "e.g. convert with: sox IN -r 16000 -c 1 -b 16 OUT.wav") from None
        return to_mono16k(x, rate)

    def _engine_for(self, sc: Scenario) -> _Engine:
        from siftom.speech.asr.base import get_engine

        key = (sc.verb, tuple(sc.world.classes), tuple(it.cls for it in sc.world.items))
        return self._engines.get_or_create(
            key, lambda: _Engine(get_engine("pocketsphinx", vocabulary=scenario_vocabulary(sc),
                                            max_seconds=self.settings.max_audio_seconds)))

    def transcribe(self, sid: str, audio: np.ndarray, nbest: int) -> Any:
        """N-best transcript with a decoder biased to the scenario's phrasings (thread-safe)."""
        eng = self._engine_for(self.scenario(sid))
        with eng.lock:
            return eng.engine.transcribe(audio, nbest=nbest)

    def infer_audio(self, sid: str, data: bytes, mode: str, likelihood: str, n_actions: int | None,
                    asr_nbest: int, top: int, policy: ClarifyPolicy, decide: str = "map") -> dict[str, Any]:
        """Detect speech in an uploaded recording, recognise it and infer (siftom.api.listen's path),
        in an audio worker process when ``audio_workers`` > 0.

        Without speech the posterior comes from the actions alone and ``speech_heard`` is false.
        """
        self.check_likelihood(likelihood)
        self.scenario(sid)  # an unknown id fails before decoding
        args = (sid, data, mode, likelihood, n_actions, asr_nbest, top, policy, decide)
        if self.audio_pool is not None:
            body: dict[str, Any] = self.audio_pool.infer_audio(*args)
            return body
        return self.infer_audio_here(*args)

    def infer_audio_here(self, sid: str, data: bytes, mode: str, likelihood: str, n_actions: int | None,
                         asr_nbest: int, top: int, policy: ClarifyPolicy, decide: str = "map") -> dict[str, Any]:
        """:meth:`infer_audio` in this process."""
        from siftom.inference.listen import NO_INSTRUCTION, NO_SPEECH, hear

        sc = self.scenario(sid)
        x = self.decode_audio(data)
        eng = self._engine_for(sc)
        with eng.lock:
            instruction, tr, vad, _ = hear(x, eng.engine, asr_nbest)
        if instruction is None:
            body = self.infer(sid, None, "action-only", "phonetic", n_actions, None, top, policy, decide)
        else:
            body = self.infer(sid, instruction, mode, likelihood, n_actions, None, top, policy, decide)
        body["asr"] = tr.to_json() if tr is not None else None
        body["speech_heard"] = instruction is not None
        body["message"] = "" if instruction is not None else NO_SPEECH
        if (body.get("evidence") or {}).get("no_instruction"):  # words near no command of the scene
            body["message"] = NO_INSTRUCTION
        body["vad"] = vad.to_json()
        return body

    # ----- speech synthesis ----------------------------------------------------------------
    @staticmethod
    def say(text: str, voice: str, rate: float, noise: str | None, snr: float, seed: int) -> bytes:
        """WAV bytes of ``text`` spoken, optionally with synthetic noise at ``snr`` dB."""
        from siftom.speech.audio import wav_bytes
        from siftom.speech.noise import SyntheticNoise, mix_at_snr
        from siftom.speech.tts import synthesize

        x = synthesize(text, voice, rate=rate)
        if noise is not None:
            x = mix_at_snr(x, SyntheticNoise(noise), snr, seed)  # synthetic kinds only: no paths
        return wav_bytes(x)

    # ----- maps ----------------------------------------------------------------------------
    def map_png(self, sid: str, command: str | None) -> Path:
        """The scenario's map as a PNG (cached under a hashed name in the service folder)."""
        from siftom.world.render import render_scenario

        sc = self.scenario(sid)
        if command is not None:
            command = str(sc.parse_command(command))
        key = hashlib.sha256(f"{sid}\n{command or ''}".encode()).hexdigest()[:32]
        path = self.map_dir / f"{key}.png"
        with self._render_lock:
            if not path.is_file():
                tmp = self.map_dir / f".{key}.{threading.get_ident()}.png"
                render_scenario(sc, tmp, command=command)
                tmp.replace(path)
        return path


def default_data_dir() -> Path:
    """A fresh private folder for the service's files (maps)."""
    return Path(tempfile.mkdtemp(prefix="siftom-serve-"))

