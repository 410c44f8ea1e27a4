"""The parts of ``siftom.api.listen`` (a recording to the posterior in one call) below the API layer.

    audio --> voice-activity detection --(no speech)--> posterior from the actions alone
                     | speech
                     v
              cut to the speech --> ASR (N-best + word times, biased to the scene's phrasings)
                     --> Instruction(nbest, samples, words) --> SIFToM posterior

Everything that depends only on the home is built once and cached, as a robot in one home
would: the recogniser per vocabulary, the model per (mode, likelihood), and the action term per
(scene, observed actions) in an ``OnlineInference``. So a call costs the detection, the
recognition and the instruction likelihood only.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from siftom.errors import ObservationError
from siftom.inference.model import Posterior
from siftom.observation import Instruction
from siftom.speech.asr import DEFAULT_NBEST

NO_SPEECH = "no speech heard"
NO_INSTRUCTION = "no instruction heard"


@dataclass(frozen=True)
class Heard:
    """The result of :func:`listen`.

    Attributes:
        posterior: the posterior (from the actions alone when no speech was heard).
        speech: whether speech was detected.
        transcript: the recogniser's output (None without speech).
        vad: the voice-activity detector's result.
        seconds: wall time from the audio (file read included) to the posterior.
        timings: seconds per stage (load, vad, asr, infer).
        instruction: False when words were heard but none near a command of the scene
            (``posterior.evidence['no_instruction_reason']`` says why): no command is issued,
            and the posterior is the one from the actions alone.
    """

    posterior: Posterior
    speech: bool
    transcript: Any
    vad: Any
    seconds: float
    timings: dict[str, float] = field(default_factory=dict)
    instruction: bool = True

    @property
    def command(self) -> str:
        """The chosen robot command ("none" when the words held no instruction)."""
        return self.posterior.command if self.instruction or not self.speech else "none"

    @property
    def message(self) -> str:
        """"no speech heard", "no instruction heard" or ''."""
        return NO_SPEECH if not self.speech else "" if self.instruction else NO_INSTRUCTION

    def to_json(self, top: int = 10) -> dict[str, Any]:
        """The posterior's JSON plus ``speech_heard``, ``message``, ``asr``, ``vad`` and timings."""
        out = self.posterior.to_json(top=top)
        out.update({
            "command": self.command,
            "speech_heard": self.speech,
            "instruction_heard": self.speech and self.instruction,
            "message": self.message,
            "asr": self.transcript.to_json() if self.transcript is not None else None,
            "vad": self.vad.to_json(),
            "seconds": round(self.seconds, 4),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        })
        return out


@dataclass(frozen=True)
class Scene:
    world: Any
    start: Any
    goals: tuple
    verb: str
    actions: tuple
    key: Any


class Cache:
    """Small thread-safe LRU for per-home objects (engines, online inferences)."""

    def __init__(self, size: int) -> None:
        self.size, self._d, self._lock = size, OrderedDict(), threading.Lock()

    def get(self, key: Any, make: Any) -> Any:
        with self._lock:
            if key in self._d:
                self._d.move_to_end(key)
                return self._d[key]
        value = make()
        with self._lock:
            self._d[key] = value
            while len(self._d) > self.size:
                self._d.popitem(last=False)
        return value


ENGINES = Cache(8)
ONLINE = Cache(64)
LOCK = threading.Lock()  # decoders and likelihood caches hold one utterance at a time


def resolve_scene(scenario: Any, world: Any, actions: Sequence[Any] | None, start: Any, goals: Any,
           verb: str | None) -> Scene:
    from siftom.scenarios.base import get_scenario
    from siftom.world.model import apply, check

    if (scenario is None) == (world is None):
        raise ObservationError("give exactly one of scenario= (an id or Scenario) or world= (a scene or World)")
    src = get_scenario(scenario) if isinstance(scenario, str) else scenario if scenario is not None else world
    if hasattr(src, "world"):  # a Scenario or a loaded scene
        w, s0, gs, vb = src.world, src.start, tuple(src.goals), verb or getattr(src, "verb", "deliver")
        default_actions = tuple(getattr(src, "actions", ()))
    else:
        if start is None or goals is None:
            raise ObservationError("with world=World give start= (its State) and goals= (the goal space)")
        w, s0, gs, vb, default_actions = src, start, tuple(goals), verb or "deliver", ()
    acts = default_actions if actions is None else []
    if actions is not None:
        s = s0
        for k, a in enumerate(actions):
            act = w.parse_action(a, s) if isinstance(a, str) else a
            why = check(w, s, act)
            if why is not None:
                raise ObservationError(f"actions[{k}] {a!r} is impossible here: {why}")
            acts.append(act)
            s = apply(s, act)
    key = (scenario if isinstance(scenario, str) else id(src), tuple(map(str, acts)))
    return Scene(w, s0, gs, vb, tuple(acts), key)


def with_likelihood(post: Posterior, name: str, why: str) -> Posterior:
    """``post`` with ``evidence['likelihood']`` (the instruction likelihood that ran) and its reason."""
    return dataclasses.replace(post, evidence={**post.evidence, "likelihood": name, "likelihood_reason": why})


def hear(x: np.ndarray, asr: Any, nbest: int = DEFAULT_NBEST) -> tuple[Instruction | None, Any, Any, dict[str, float]]:
    """Detect speech, cut to it and recognise it: (instruction or None, transcript, vad, timings)."""
    from siftom.speech.vad import detect_speech, trim

    t0 = time.perf_counter()
    vad = detect_speech(x)
    t1 = time.perf_counter()
    timings = {"vad": t1 - t0}
    if not vad.speech:
        return None, None, vad, timings
    y = trim(x, vad)
    tr = asr.transcribe(y, nbest=nbest)
    timings["asr"] = time.perf_counter() - t1
    if not tr.text:
        return None, tr, vad, timings
    instruction = dataclasses.replace(tr.to_instruction(samples=y), snr_db=vad.snr_db)
    return instruction, tr, vad, timings
