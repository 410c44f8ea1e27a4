"""A registered ASR engine decoding in its own, persistent Python process.

pocketsphinx holds the GIL while it decodes, so two decoders in threads of one process run one
after the other. :class:`EngineWorker` keeps one engine warm in a child process (started with
``python -m siftom.speech.asr.worker``) and talks to it over its stdin/stdout pipes:

    worker = EngineWorker("pocketsphinx-open", vocabulary=phrases)   # starts building at once
    worker.submit(samples, nbest=5)     # returns immediately; the child decodes
    ...                                 # meanwhile decode something else in this process
    transcript = worker.result()        # wait for the child's Transcript

Robustness: the child exits when its stdin closes (the parent ended, even by SIGKILL), ignores
Ctrl-C (the parent's to handle), and never writes anything but replies to the protocol pipe
(its fd 1 is pointed at stderr). A worker belongs to the process that started it: after a
``fork`` (process pools) the copy is unusable (:meth:`usable` is False) and the caller starts
its own. Every failure (cannot start, child died, timeout, error reply) raises
:class:`WorkerError`, after which the worker is closed; callers fall back to decoding in-process.
A process keeps at most ``SIFTOM_ASR_WORKERS`` workers (default MAX_WORKERS = 2; the least
recently used one is closed for a new one, its engine starts it again when next used);
``SIFTOM_ASR_WORKERS=0`` turns worker processes off (:func:`workers_enabled`).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import sys
import threading
import weakref
from collections import OrderedDict
from collections.abc import Sequence
from multiprocessing.connection import Connection
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.errors import SiftomError
from siftom.settings.environment import asr_workers
from siftom.speech.audio import SAMPLE_RATE

if TYPE_CHECKING:
    from siftom.speech.asr.base import Transcript

log = logging.getLogger(__name__)

MAX_WORKERS = 2  # per process: the scene's decoder and one more (e.g. an answer grammar's)
START_TIMEOUT_S = 120.0  # importing siftom + building a decoder; generous for a loaded machine
DECODE_TIMEOUT_S = 60.0  # on top of 2 s per second of audio


class WorkerError(SiftomError):
    """The worker process could not start, died, or did not answer in time; decode in-process."""


def max_workers() -> int:
    """How many worker processes one process keeps (``SIFTOM_ASR_WORKERS``, default
    MAX_WORKERS; 0 = none: decode everything in the calling process)."""
    return asr_workers(MAX_WORKERS)


def workers_enabled() -> bool:
    """False when ``SIFTOM_ASR_WORKERS=0`` (decode everything in the calling process)."""
    return max_workers() > 0


# the live workers of this process, least recently used first (evicted beyond max_workers())
_LIVE: OrderedDict[int, weakref.ReferenceType[EngineWorker]] = OrderedDict()
_LIVE_LOCK = threading.Lock()


def _admit(worker: EngineWorker) -> None:
    """Register a new worker; close the least recently used ones beyond the limit."""
    with _LIVE_LOCK:
        for key in [k for k, r in _LIVE.items() if (w := r()) is None or not w.usable]:
            del _LIVE[key]
        _LIVE[id(worker)] = weakref.ref(worker)
        while len(_LIVE) > max(1, max_workers()):
            _, ref = _LIVE.popitem(last=False)
            old = ref()
            if old is not None:
                old.evicted = True
                old.close()


def _touch(worker: EngineWorker) -> None:
    with _LIVE_LOCK:
        if id(worker) in _LIVE:
            _LIVE.move_to_end(id(worker))


def _shutdown(proc: subprocess.Popen[bytes], conns: tuple[Connection, ...], owner: int) -> None:
    """Close the pipes and end the child (a forked copy only closes its copies of the pipes)."""
    for c in conns:
        with contextlib.suppress(OSError):
            c.close()
    if os.getpid() != owner:
        return
    try:
        proc.wait(timeout=2.0)  # stdin closed: the child leaves its loop by itself
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=5.0)
    except OSError:
        pass


class EngineWorker:
    """One registered engine (``get_engine(name, vocabulary, **options)``) in a child process.

    Args:
        name: registered engine name.
        vocabulary: the scene's phrasings for a scene engine, else None.
        options: keyword arguments for the engine (must pickle).

    Raises:
        WorkerError: the child process cannot be started.
    """

    def __init__(self, name: str, vocabulary: Sequence[str] | None = None, **options: Any) -> None:
        """Start the child and send it the engine to build (does not wait for it)."""
        self.name = name
        self.owner = os.getpid()
        self._lock = threading.Lock()
        self._ready = False
        self._pending = False
        self._audio_s = 0.0
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[3])  # this siftom (src/siftom/speech/asr/worker.py), wherever it was imported from
        env["PYTHONPATH"] = os.pathsep.join([root, *([env["PYTHONPATH"]] if env.get("PYTHONPATH") else [])])
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "siftom.speech.asr.worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                env=env, start_new_session=True, close_fds=True)
        except OSError as exc:
            raise WorkerError(f"cannot start an ASR worker process ({exc}); decoding in this process instead") from None
        if self._proc.stdin is None or self._proc.stdout is None:  # cannot happen with PIPE; keeps mypy honest
            raise WorkerError("the ASR worker process has no pipes")
        self._send = Connection(os.dup(self._proc.stdin.fileno()), readable=False)
        self._recv = Connection(os.dup(self._proc.stdout.fileno()), writable=False)
        self._proc.stdin.close()
        self._proc.stdout.close()
        self._finalizer = weakref.finalize(self, _shutdown, self._proc, (self._send, self._recv), self.owner)
        self.evicted = False  # closed to make room for a newer worker (not a failure)
        _admit(self)
        self._request(("load", name, None if vocabulary is None else list(vocabulary), options))

    @property
    def usable(self) -> bool:
        """Whether this process may use the worker (it started it, and the worker is alive)."""
        return os.getpid() == self.owner and self._finalizer.alive and self._proc.poll() is None

    def is_ready(self) -> bool:
        """Whether the child has built its engine (never blocks). Raises WorkerError on failure."""
        try:
            arrived = not self._ready and self._recv.poll(0)
        except (OSError, ValueError):
            raise WorkerError("the ASR worker process was closed") from None
        if arrived:
            self._reply(0.0)
            self._ready = True
        return self._ready

    def wait_ready(self, timeout: float = START_TIMEOUT_S) -> None:
        """Block until the child has built its engine. Raises WorkerError on failure."""
        if not self._ready:
            self._reply(timeout)
            self._ready = True

    def submit(self, audio: np.ndarray, nbest: int = 1) -> None:
        """Send 16 kHz float samples to decode; collect the Transcript with :meth:`result`."""
        self.wait_ready()
        if self._pending:
            raise WorkerError("an ASR worker decodes one utterance at a time; call result() first")
        _touch(self)
        self._request(("decode", np.ascontiguousarray(audio, dtype=np.float32), int(nbest)))
        self._pending = True
        self._audio_s = audio.size / SAMPLE_RATE

    def result(self, timeout: float | None = None) -> Transcript:
        """The Transcript of the last :meth:`submit` (waits at most ``timeout`` seconds)."""
        if not self._pending:
            raise WorkerError("nothing was submitted to the ASR worker")
        self._pending = False
        tr: Transcript = self._reply(DECODE_TIMEOUT_S + 2.0 * self._audio_s if timeout is None else timeout)
        return tr

    def transcribe(self, audio: np.ndarray, nbest: int = 1) -> Transcript:
        """submit + result, one caller at a time."""
        with self._lock:
            self.submit(audio, nbest)
            return self.result()

    def close(self) -> None:
        """End the child process (idempotent; also runs when the worker is garbage-collected or at exit)."""
        self._finalizer()

    def _request(self, msg: tuple[Any, ...]) -> None:
        if not self.usable:
            raise WorkerError("the ASR worker process is not running (it ended or belongs to another process)")
        try:
            self._send.send(msg)
        except (OSError, ValueError) as exc:
            self.close()
            raise WorkerError(f"the ASR worker process stopped listening ({exc})") from None

    def _reply(self, timeout: float) -> Any:
        try:
            if not self._recv.poll(timeout):
                self.close()
                raise WorkerError(f"the ASR worker process did not answer within {timeout:.0f} s")
            status, payload = self._recv.recv()
        except (EOFError, OSError, ValueError) as exc:
            self.close()
            raise WorkerError(f"the ASR worker process ended unexpectedly ({type(exc).__name__})") from None
        if status != "ok":
            self.close()
            raise WorkerError(f"the ASR worker failed: {payload}")
        return payload


class WorkerEngine:
    """A scene engine that decodes in a warm :class:`EngineWorker`, so the calling process's other
    threads keep running while pocketsphinx decodes (it holds the GIL for the whole utterance,
    about 0.1 s for a 2 s request: a server's other requests would wait that long).

    The transcript is the one ``local`` gives: the same engine, built with the same arguments, in
    the child. The worker starts building at once; until it is ready, and for good after it fails
    (or where worker processes are off), ``local`` decodes here. A worker closed to make room for
    another (:data:`MAX_WORKERS` per process) is started again at most once a minute; meanwhile
    ``local`` decodes.

    Args:
        local: the engine built in this process (also the fallback).
        name: its registered name; vocabulary, options: what it was built with (must pickle).
    """

    RESTART_S = 60.0

    def __init__(self, local: Any, name: str, vocabulary: Sequence[str] | None = None, **options: Any) -> None:
        self.local = local
        self._spec = (name, None if vocabulary is None else list(vocabulary), options)
        self._worker: EngineWorker | None = None
        self._off = not workers_enabled()
        self._started = float("-inf")
        self._lock = threading.Lock()
        with self._lock:
            self._ready()  # start building the worker now: a server's first utterance should find it ready

    def __getattr__(self, attr: str) -> Any:  # name, unknown_words, phrases, max_seconds: the local engine's
        return getattr(self.__dict__["local"], attr)

    @property
    def in_worker(self) -> bool:
        """Whether the next decode would run in the worker process."""
        with self._lock:
            return self._ready() is not None

    def transcribe(self, audio: Any, nbest: int = 1) -> Transcript:
        """The local engine's transcript of ``audio``, decoded in the worker when it is ready."""
        from siftom.speech.audio import DEFAULT_MAX_SECONDS, as_audio

        x = as_audio(audio, max_seconds=getattr(self.local, "max_seconds", DEFAULT_MAX_SECONDS))  # refused here
        with self._lock:
            w = self._ready()
        if w is None:
            tr: Transcript = self.local.transcribe(x, nbest=nbest)
            return tr
        try:
            return w.transcribe(x, nbest=nbest)
        except WorkerError as exc:
            with self._lock:
                self._worker, self._off = None, True
            log.warning("decoding in this process from now on: %s", exc)
            tr = self.local.transcribe(x, nbest=nbest)
            return tr

    def close(self) -> None:
        """End the worker process (decoding goes on here)."""
        with self._lock:
            if self._worker is not None:
                self._worker.close()
            self._worker, self._off = None, True

    def _ready(self) -> EngineWorker | None:
        """The worker when it can decode now; starts it when there is none (caller holds the lock)."""
        import time

        if self._off:
            return None
        w = self._worker
        if w is not None and (w.evicted or not w.usable):
            w.close()
            self._worker = w = None
        if w is None:
            if time.monotonic() - self._started < self.RESTART_S:
                return None
            self._started = time.monotonic()
            name, vocabulary, options = self._spec
            try:
                self._worker = EngineWorker(name, vocabulary, **options)
            except WorkerError as exc:
                self._off = True
                log.warning("decoding in this process: %s", exc)
            return None  # starting: decode here this time rather than wait
        try:
            return w if w.is_ready() else None
        except WorkerError as exc:
            self._worker, self._off = None, True
            log.warning("decoding in this process: %s", exc)
            return None


def main() -> int:
    """The child's loop: build the engine, then decode until stdin closes or "quit" arrives."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    out_fd = os.dup(1)
    os.dup2(2, 1)  # stray prints (Python or C) go to stderr, never into the protocol pipe
    recv = Connection(os.dup(0), writable=False)
    send = Connection(out_fd, readable=False)
    engine: Any = None
    while True:
        try:
            msg = recv.recv()
        except (EOFError, OSError):
            return 0
        try:
            if msg[0] == "quit":
                return 0
            if msg[0] == "load":
                from siftom.speech.asr.base import get_engine

                _, name, vocabulary, options = msg
                engine = get_engine(name, vocabulary=vocabulary, **options)
                send.send(("ok", None))
            elif msg[0] == "decode":
                if engine is None:
                    raise SiftomError("no engine loaded")
                send.send(("ok", engine.transcribe(msg[1], nbest=msg[2])))
            else:
                raise SiftomError(f"unknown request {msg[0]!r}")
        except (EOFError, OSError, BrokenPipeError):
            return 0
        except Exception as exc:  # reported to the parent, which falls back to in-process decoding
            try:
                send.send(("error", f"{type(exc).__name__}: {exc}"))
            except OSError:
                return 0


if __name__ == "__main__":
    sys.exit(main())
