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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from siftom.inference.model import Posterior
from siftom.observation import Instruction
from siftom.speech.asr import DEFAULT_NBEST

NO_SPEECH = "no speech heard"
NO_INSTRUCTION = "no instruction heard"
T = TypeVar("T")


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
        """The chosen robot command (a RobotCommand; "none" when the words held no instruction)."""
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


class Cache:
    """A small thread-safe LRU map with get-or-create (engines, online inferences, plans).

    ``make`` runs outside the lock (creation may be slow); two threads that miss at once may
    both create, and the last one is kept.
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self._d: OrderedDict[Any, Any] = OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._d)

    def get_or_create(self, key: Any, make: Callable[[], T]) -> T:
        """The value for ``key``, made by ``make()`` on a miss."""
        return self.get(key, make)

    def get(self, key: Any, make: Callable[[], Any]) -> Any:
        """The value for ``key``, made by ``make()`` on a miss."""
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
