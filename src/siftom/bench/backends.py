"""Where the work of ``dataset build`` and ``eval`` runs: here, a process pool, or Ray.

A backend maps a module-level function over work items and yields ``(index, result)`` as
results come in (in any order; callers put them back in a fixed order, so the output does not
depend on the backend). Large inputs that every item needs (``shared``: the ASR vocabulary,
the build options) are shipped once: to each pool worker when it starts, or put in Ray's object
store once and passed by reference. Workers rebuild worlds, planners and ASR models from ids
and cache them per process (see docs/scaling.md).

Backends (by name):

* ``local``: ``workers`` processes of this machine (1 = in this process);
* ``ray``: Ray tasks of one CPU each, on a local Ray instance started for the run
  (``address=None``; ``workers`` CPUs) or on a running cluster (``address="auto"`` or
  ``"HOST:PORT"``). Needs ``pip install "siftom[ray]"``.

``close()`` stops every worker at once (pool workers are terminated, Ray tasks force-cancelled
and a Ray instance started here shut down): it is what SIGINT / SIGTERM end in.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from siftom.errors import DatasetError, missing_extra, unknown_name

BACKENDS = ("local", "ray")

Work = Callable[[Any, Any], Any]  # fn(item, shared) -> result


class LocalBackend:
    """A pool of ``workers`` processes on this machine (or this process when 1)."""

    name = "local"

    def __init__(self, workers: int = 1) -> None:
        if workers < 1:
            raise DatasetError(f"--workers must be >= 1, got {workers}")
        self.workers = workers
        self._pool: Any = None

    @property
    def inline(self) -> bool:
        """True when the work runs in this process (no pool)."""
        return self.workers <= 1

    def map_unordered(self, fn: Work, items: Sequence[Any], shared: Any = None) -> Iterator[tuple[int, Any]]:
        """Yield (index, fn(item, shared)) as items finish."""
        if self.inline or len(items) <= 1:
            for i, it in enumerate(items):
                yield i, fn(it, shared)
            return
        ctx = multiprocessing.get_context(_start_method())
        self._pool = ctx.Pool(min(self.workers, len(items)), initializer=_init_worker, initargs=(fn, shared))
        try:
            yield from self._pool.imap_unordered(_call, list(enumerate(items)))
        finally:
            self.close()

    def close(self) -> None:
        """Stop the workers now (running items are lost; callers resume them)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    shutdown = close


_WORK: tuple[Work, Any] | None = None
# native runtimes that start threads of their own (Whisper's, the neural VAD's): a process that
# has loaded one must not fork (a child can inherit a held lock and hang)
_THREADED_RUNTIMES = ("ctranslate2", "onnxruntime", "torch")


def _start_method() -> str:
    """``fork`` (cheap, shares what the parent built) unless a threaded runtime is loaded here."""
    import sys

    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and not any(m in sys.modules for m in _THREADED_RUNTIMES):
        return "fork"
    return "forkserver" if "forkserver" in methods else "spawn"


def _init_worker(fn: Work, shared: Any) -> None:
    import signal

    global _WORK
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides; Ctrl-C reaches the whole group
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _WORK = (fn, shared)


def _call(arg: tuple[int, Any]) -> tuple[int, Any]:
    assert _WORK is not None  # set by _init_worker
    i, item = arg
    return i, _WORK[0](item, _WORK[1])


def _ray_call(fn: Work, item: Any, shared: Any) -> tuple[str, Any]:
    """Run one item on a Ray worker; report the worker's code hash with the result."""
    from siftom.bench.results_io import code_version

    return code_version()["source_sha1"], fn(item, shared)


class RayBackend:
    """Ray tasks of one CPU each; a local Ray instance is started when no address is given."""

    name = "ray"
    inline = False

    def __init__(self, address: str | None = None, workers: int | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise missing_extra("ray", "ray") from None
        if workers is not None and workers < 1:
            raise DatasetError(f"--workers must be >= 1, got {workers}")
        self._ray = ray
        self.started = False
        if not ray.is_initialized():
            kw: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                  "configure_logging": True, "logging_level": "warning"}
            if address is None:
                # workers inherit this environment (PYTHONPATH included), so they import this siftom
                ray.init(num_cpus=workers or os.cpu_count() or 1, **kw)
            else:
                _probe(address)
                try:
                    ray.init(address=address, **kw)
                except ConnectionError as exc:
                    raise DatasetError(f"cannot reach a Ray cluster at {address!r} ({exc}); start one with "
                                       "'ray start --head' or give --ray-address HOST:PORT") from None
            self.started = True
        cpus = _cluster_cpus(ray)
        self.workers = min(workers, cpus) if workers and address is not None else (workers or cpus)
        self._pending: dict[Any, int] = {}
        self._remote = ray.remote(num_cpus=1, max_retries=1)(_ray_call)

    def map_unordered(self, fn: Work, items: Sequence[Any], shared: Any = None) -> Iterator[tuple[int, Any]]:
        """Yield (index, fn(item, shared)) as tasks finish; ``shared`` goes to the object store once."""
        from siftom.bench.results_io import code_version

        ray = self._ray
        ref = ray.put(shared)
        mine = code_version()["source_sha1"]
        todo = list(enumerate(items))
        todo.reverse()
        limit = 2 * self.workers  # a few queued per worker keeps them busy without flooding memory
        try:
            while todo or self._pending:
                while todo and len(self._pending) < limit:
                    i, it = todo.pop()
                    self._pending[self._remote.remote(fn, it, ref)] = i
                # a short timeout keeps this thread responsive to SIGINT / SIGTERM
                ready, _ = ray.wait(list(self._pending), num_returns=1, timeout=0.5)
                for r in ready:
                    i = self._pending.pop(r)
                    theirs, result = ray.get(r)
                    if theirs != mine:
                        raise DatasetError(
                            f"a Ray worker runs other siftom code (source {theirs}) than this driver "
                            f"({mine}); install the same siftom on every node, or results would mix versions"
                        )
                    yield i, result
        finally:
            self.close()

    def close(self) -> None:
        """Cancel what is still running; shut down a Ray instance started here."""
        for r in list(self._pending):
            with contextlib.suppress(Exception):  # already finished or gone: nothing to stop
                self._ray.cancel(r, force=True)
        self._pending.clear()

    def shutdown(self) -> None:
        """Stop the Ray instance if this backend started it."""
        self.close()
        if self.started:
            self._ray.shutdown()
            self.started = False


def _cluster_cpus(ray: Any) -> int:
    """The CPUs of the Ray cluster (the module comes in as Any: ``cluster_resources`` is untyped in
    Ray's own annotations, and Ray may not be installed where this is type-checked)."""
    resources: dict[str, float] = ray.cluster_resources()
    return int(resources.get("CPU", 1))


def _probe(address: str) -> None:
    """Fail fast on an unreachable HOST:PORT (ray.init would retry for minutes)."""
    import socket

    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if address == "auto" or not sep or not port.isdigit():
        return
    try:
        socket.create_connection((host or "127.0.0.1", int(port)), timeout=5).close()
    except OSError as exc:
        raise DatasetError(f"cannot reach a Ray cluster at {address!r} ({exc.strerror or exc}); start one with "
                           "'ray start --head' (it prints the address) or give --ray-address auto on a cluster node") from None


def check_backend_args(name: str, address: str | None) -> None:
    """Refuse flag combinations before anything is started or locked."""
    if name not in BACKENDS:
        raise unknown_name("backend", name, BACKENDS)
    if address is not None and name != "ray":
        raise DatasetError("--ray-address needs --backend ray")


def make_backend(name: str = "local", workers: int | None = None, address: str | None = None) -> Any:
    """A backend by name; ``address`` applies to ``ray`` only (None: start a local instance)."""
    check_backend_args(name, address)
    if name == "local":
        return LocalBackend(workers or 1)
    return RayBackend(address, workers)
