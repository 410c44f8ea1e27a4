"""The service's working parts, safe to call from many threads at once.

* Inference: the app's one :class:`~siftom.observer.Observer` (built from the same settings as
  ``siftom.infer``) owns the models, recognisers and the action term of each scenario prefix, so
  a request only scores what was heard (~2 ms); the answer is the observer's (act, ask or none).
* ASR: the observer's recogniser per scenario vocabulary, each behind a lock (a decoder holds
  one utterance at a time, and holds the GIL while it decodes); with ``audio_workers`` > 0,
  audio requests run in worker processes instead, several at once (service/audio_pool.py).
  Streams share a pool of recognisers per vocabulary, one per CPU of the admission budget (the
  observer's and those of helper observers built from the same settings: the same engine, the
  same transcript), so the utterances of a burst decode side by side
  (:meth:`Runtime.stream_recogniser`).
* Maps: matplotlib's pyplot is not thread-safe; rendering is serialised and PNGs are cached
  in the service's own folder under names it makes (a hash), never a client's string.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io
import queue
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from siftom.answer import Answer
from siftom.assist.clarify import clarify
from siftom.assist.route import RobotPlan, robot_plan
from siftom.errors import AudioError, ObservationError, SiftomError
from siftom.inputs import SceneInput
from siftom.memo import Memo
from siftom.observer import Observer
from siftom.options import (
    SERVICE_LIKELIHOODS,
    ServiceSettings,
    available_likelihoods,
    service_llm_config,
)
from siftom.private import private_dir
from siftom.scenarios.base import Scenario, get_scenario, scenario_ids
from siftom.service.admission import Admission
from siftom.service.infer_reply import InferCall, InferReply
from siftom.settings import Settings
from siftom.settings.llm import LLMStatus

if TYPE_CHECKING:
    from siftom.inference.stream import Recognised
    from siftom.world.model import World

__all__ = ["SERVICE_LIKELIHOODS", "InferCall", "InferReply", "Runtime", "ServiceSettings", "available_likelihoods", "default_data_dir",
           "scenario_vocabulary", "service_llm_config"]

T = TypeVar("T")

def scenario_vocabulary(scenario: Scenario) -> list[str]:
    """Every phrasing of every command of the scenario: the ASR's language model."""
    from siftom.api import vocabulary_for

    return sorted(vocabulary_for(scenario.world, scenario.verb))


class Runtime:
    """Caches and locks shared by the request handlers (see module doc); inference goes through
    the app's one :class:`~siftom.observer.Observer`."""

    def __init__(self, settings: ServiceSettings, data_dir: Path, observer: Observer | None = None,
                 owns_dir: bool = False) -> None:
        self.settings = settings
        self.data_dir = data_dir
        self.owns_dir = owns_dir  # a temporary folder made for this runtime: close() removes it
        self.closers: list[Any] = []  # called by close() before the folder goes (the session store)
        self.map_dir = data_dir / "maps"
        private_dir(self.map_dir)
        self.started = time.time()
        self.observer = observer if observer is not None else Observer(
            offered=settings.offered, max_audio_seconds=settings.max_audio_seconds)
        self._scenes: Memo[SceneInput] = Memo("service.scenes", settings.cache_size)
        self._plans: Memo[RobotPlan | None] = Memo("service.plans", 1024)
        self._render_lock = threading.Lock()
        self.requests = 0
        # one CPU budget for every utterance this process answers: streams and audio requests
        self.admission = Admission()
        self.audio_pool: Any = None
        if settings.audio_workers > 0:
            from siftom.service.audio_pool import AudioPool

            self.audio_pool = AudioPool(settings, self.observer.settings, worker_runtime)
        self._warm: threading.Thread | None = None
        self._hearers: list[Observer] = []  # helper observers: more recognisers per vocabulary
        self._pools: dict[int, tuple[Any, queue.SimpleQueue[Any]]] = {}  # per vocabulary: free recognisers
        self._pools_lock = threading.Lock()

    def warm_up(self) -> None:
        """Start loading the default audio model in the background (once), so that the first
        recording does not wait for it; the app's start-up calls this."""
        if self._warm is None:
            self._warm = threading.Thread(target=self._load_default_audio_model, daemon=True)
            self._warm.start()

    def wait_warm(self, timeout: float | None = None) -> None:
        """Wait for :meth:`warm_up`'s loading to finish (at once when it was not started)."""
        if self._warm is not None:
            self._warm.join(timeout)

    def close(self) -> None:
        """Stop the audio worker processes, if any, close the stores and remove the data folder
        when it is a temporary one made for this runtime. Safe to call twice."""
        if self.audio_pool is not None:
            self.audio_pool.close()
        with self._pools_lock:  # the helper recognisers' worker processes stop once collected
            self._pools.clear()
            self._hearers.clear()
        while self.closers:
            with contextlib.suppress(Exception):  # closing what is already closed
                self.closers.pop()()
        if self.owns_dir:
            import shutil

            shutil.rmtree(self.data_dir, ignore_errors=True)
            self.owns_dir = False

    def _load_default_audio_model(self) -> None:
        """Load the acoustic model (Whisper) in the background, so the first recording, which gets it
        by default, does not wait for the model to load."""
        try:
            if self.observer.resolve(None, True)[0] != "acoustic":
                return
            lk = self.observer.model("full", "acoustic").likelihood
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

    def llm_status(self) -> LLMStatus:
        """What /healthz says about the language model (never the API key)."""
        return LLMStatus("llm" in (self.settings.likelihoods or ()), self.settings.llm,
                         self.settings.llm_error or None)

    def check_likelihood(self, name: str | None) -> None:
        """A likelihood this server does not offer is a 422 naming those it does."""
        if name is not None:
            self.observer.check_likelihood(name)

    # ----- inference ---------------------------------------------------------------------
    def scene(self, sid: str, n_actions: int | None = None, actions: list[str] | None = None) -> SceneInput:
        """The scenario with its first ``n_actions`` actions (all by default) or the caller's own."""
        from siftom.inputs import resolve_scene

        sc = self.scenario(sid)
        if actions is not None:
            return resolve_scene(sid, list(actions))
        n = len(sc.actions) if n_actions is None else n_actions
        if not 0 <= n <= len(sc.actions):
            raise ObservationError(f"n_actions must be between 0 and {len(sc.actions)} for {sid}")
        got: SceneInput = self._scenes.get((sid, n), lambda: resolve_scene(sid, list(sc.actions[:n])))
        return got

    def plan(self, sid: str, n_actions: int | None, actions: list[str] | None, command: str | None) -> RobotPlan | None:
        """The robot's plan for ``command`` from the state when the human spoke (cached)."""
        if actions is not None or command is None:
            return None  # a custom action sequence: no cached state to plan from
        sc = self.scenario(sid)
        n = len(sc.actions) if n_actions is None else n_actions
        state = sc.states()[n]
        try:
            cmd = sc.parse_command(command)
        except Exception:  # the MAP command is always the scenario's; be safe anyway
            return None
        return self._plans.get(
            (sid, n, str(cmd)), lambda: robot_plan(sc, state, cmd, max_time=self.settings.plan_max_time))

    def answer(self, call: InferCall) -> Answer:
        """The observer's answer to ``call`` (thread-safe)."""
        self.check_likelihood(call.likelihood)
        actions = list(call.actions) if call.actions is not None else None
        scene = self.scene(call.scenario, call.n_actions, actions)
        obs = self.observer
        return obs.answer(obs.online(scene, call.mode), call.instruction, likelihood=call.likelihood,
                          decide=call.rule, top=call.top, heard=call.heard, mode=call.mode)

    def infer(self, call: InferCall) -> InferReply:
        """The answer of ``POST /v1/infer``."""
        ans = self.answer(call)
        top = call.top or self.observer.settings.infer.top
        actions = list(call.actions) if call.actions is not None else None
        plan = self.plan(call.scenario, call.n_actions, actions, str(ans.command) if ans.command is not None else None)
        instruction = call.instruction
        return InferReply(call.scenario, ans.to_json(top=top),
                          tuple((h.text, h.score) for h in (instruction.nbest if instruction else ())),
                          clarify(ans.commands, call.policy), plan)

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

    def stream_recogniser(self, world: World, verb: str, nbest: int) -> Callable[[np.ndarray], Recognised]:
        """A stream's recognition of its utterances: the first free recogniser of the scene's pool
        (one per CPU of the admission budget), counted in the admission queue meanwhile."""
        from siftom.inference.stream import recogniser

        pool = self._pool(world, verb)
        admission = self.admission

        def recognise(samples: np.ndarray) -> Recognised:
            with admission.recognising():
                rec = pool.get()
                try:
                    return recogniser(rec.engine, nbest, rec.lock)(samples)
                finally:
                    pool.put(rec)

        return recognise

    def _pool(self, world: World, verb: str) -> queue.SimpleQueue[Any]:
        first = self.observer.recogniser(world, verb)  # one per vocabulary (the observer's memo)
        with self._pools_lock:
            got = self._pools.get(id(first))
            if got is not None and got[0] is first:
                return got[1]
            obs = self.observer
            while len(self._hearers) < self.admission.budget - 1:
                self._hearers.append(Observer(obs.settings, offered=obs.offered, max_audio_seconds=obs.max_audio_seconds,
                                              decode_in_worker=obs.decode_in_worker))
            pool: queue.SimpleQueue[Any] = queue.SimpleQueue()
            for rec in (first, *(h.recogniser(world, verb) for h in self._hearers)):
                pool.put(rec)
            self._pools[id(first)] = (first, pool)
            return pool

    def transcribe(self, sid: str, audio: np.ndarray, nbest: int) -> Any:
        """N-best transcript with a decoder biased to the scenario's phrasings (thread-safe)."""
        sc = self.scenario(sid)
        return self.observer.recogniser(sc.world, sc.verb).transcribe(audio, nbest)

    def infer_audio(self, call: InferCall) -> InferReply:
        """Detect speech in the call's recording, recognise it and infer (the observer's path),
        in an audio worker process when ``audio_workers`` > 0.

        Without speech the posterior comes from the actions alone and the action is none.
        """
        self.check_likelihood(call.likelihood)
        self.scenario(call.scenario)  # an unknown id fails before decoding
        if self.audio_pool is not None:
            reply: InferReply = self.audio_pool.infer_audio(call)
            return reply
        return self.infer_audio_here(call)

    def infer_audio_here(self, call: InferCall) -> InferReply:
        """:meth:`infer_audio` in this process."""
        sc = self.scenario(call.scenario)
        x = self.decode_audio(call.audio or b"")
        with self.admission.recognising():  # in the queue the CPU budget sees
            heard = self.observer.hear(x, sc.world, sc.verb, nbest=call.asr_nbest)
        call = call.with_(audio=None, heard=heard, instruction=heard.instruction, actions=None)
        with self.admission.slot(call.likelihood) as slot:  # past the CPU budget the default likelihood gives way
            reply = self.infer(call.with_(likelihood=slot.likelihood or call.likelihood,
                                          rule=slot.rule(call.rule, self.observer.settings)))
        return dataclasses.replace(reply, degraded=slot.reason)

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
    """A fresh private folder (0700) for the service's files; :meth:`Runtime.close` removes it."""
    return Path(tempfile.mkdtemp(prefix="siftom-serve-"))


def worker_runtime(settings: ServiceSettings, full: Settings) -> Runtime:
    """An audio worker process's runtime: the same settings as the service's own observer, so
    the same answers (service/audio_pool.py)."""
    from siftom.observer import Observer

    observer = Observer(full, offered=settings.offered, max_audio_seconds=settings.max_audio_seconds)
    rt = Runtime(settings, default_data_dir(), observer)
    rt.warm_up()  # the worker's start-up
    return rt
