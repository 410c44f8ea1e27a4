"""Audio requests scored in worker processes, so several run at once.

pocketsphinx holds the GIL while it decodes, so audio requests in threads of one process run
one after the other. With ``ServiceSettings.audio_workers = N > 0`` the service sends each
audio request (decoding, voice-activity detection, recognition, the likelihood and the
posterior) to one of N worker processes; each worker keeps its own recognisers, models and
cached action terms warm, as the service process does. With 0, requests are scored in the
request thread (the recogniser of a scene decodes one utterance at a time).

The workers start with ``spawn`` (a fresh interpreter; never a fork of a threaded server) on
the first audio request and stop with the app.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING, Any

from siftom.errors import SiftomError

if TYPE_CHECKING:
    from siftom.options import ServiceSettings
    from siftom.service.infer_reply import InferCall, InferReply
    from siftom.settings import Settings

# builds a worker's runtime from the service's settings (a module-level function: it is pickled
# by name into the spawned worker); the runtime answers ``infer_audio_here(call)``
WorkerFactory = Callable[["ServiceSettings", "Settings"], Any]

_WORKER: Any = None  # the worker process's own runtime


def _start(factory: WorkerFactory, settings: ServiceSettings, full: Settings) -> None:
    global _WORKER
    _WORKER = factory(settings, full)


def _infer_audio(call: InferCall) -> InferReply:
    if _WORKER is None:
        raise SiftomError("the audio worker did not start")
    reply: InferReply = _WORKER.infer_audio_here(call)
    return reply


def _ready() -> bool:
    return _WORKER is not None


class AudioPool:
    """N worker processes for audio requests (started on first use)."""

    def __init__(self, settings: ServiceSettings, full: Settings, factory: WorkerFactory) -> None:
        self.size = settings.audio_workers
        self._factory = factory
        self._full = full
        # the workers score in-process: they must not start pools of their own
        self._settings = dataclasses.replace(settings, audio_workers=0)
        self._pool: ProcessPoolExecutor | None = None
        self._lock = threading.Lock()

    def _executor(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._pool is None:
                self._pool = ProcessPoolExecutor(self.size, mp_context=multiprocessing.get_context("spawn"),
                                                 initializer=_start, initargs=(self._factory, self._settings, self._full))
            return self._pool

    def warm(self) -> None:
        """Start every worker now (each imports siftom once), instead of on the first requests."""
        ex = self._executor()
        for f in [ex.submit(_ready) for _ in range(self.size)]:
            f.result()

    def infer_audio(self, call: InferCall) -> InferReply:
        """``Runtime.infer_audio_here(call)`` in a worker; its SiftomError is raised here."""
        try:
            return self._executor().submit(_infer_audio, call).result()
        except BrokenProcessPool:
            with self._lock:
                self._pool = None  # a worker died (e.g. out of memory): start afresh next time
            raise SiftomError("an audio worker process stopped; send the request again") from None

    def close(self, timeout: float = 3.0) -> None:
        """Stop the workers: queued requests are cancelled, a request being scored gets ``timeout``
        seconds to finish, then its worker is terminated (a stop must not wait on a long job)."""
        with self._lock:
            pool, self._pool = self._pool, None
        if pool is None:
            return
        procs = list((getattr(pool, "_processes", None) or {}).values())  # before shutdown forgets them
        pool.shutdown(wait=False, cancel_futures=True)
        deadline = time.monotonic() + timeout
        for p in procs:
            p.join(max(0.0, deadline - time.monotonic()))
        for p in procs:
            if p.is_alive():
                p.terminate()
                p.join(1.0)
