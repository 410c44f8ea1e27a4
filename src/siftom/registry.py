"""One registry shape for everything pluggable (Gymnasium's ``register``/``make``).

Likelihoods, ASR engines, voices, LLM/VLM backends, domains and decision rules are each a
:class:`Registry` of :class:`Entry` values: a name, a lazy ``"module:attr"`` entry point, and
what the entry needs (Python modules from an extra, programs on the PATH, or a custom check).
``check`` explains a refusal *before* anything is imported or constructed, so a missing extra
is a one-line error with the ``pip install`` that fixes it::

    from siftom.registry import Registry

    ENGINES = Registry("ASR engine", default="pocketsphinx")
    ENGINES.register("whisper", "siftom.speech.asr.whisper:WhisperEngine",
                     requires=("faster_whisper",), extra="whisper", summary="...")
    ENGINES.make("whisper", vocabulary=...)   # check, import, construct

Every registry created here is listed by :func:`registries`, which the CLI (``siftom
plugins``) and the service (``/healthz``) use to say what is installed.

Other packages add to any registry without editing siftom: they declare an entry point in the
group ``siftom.plugins`` naming a function that registers their entries, e.g. in their
``pyproject.toml``::

    [project.entry-points."siftom.plugins"]
    mypkg = "mypkg.siftom_plugin:register"

    # mypkg/siftom_plugin.py
    def register() -> None:
        from siftom.likelihood.registry import LIKELIHOODS
        LIKELIHOODS.register("mine", "mypkg.lk:MyLikelihood", summary="...")

The first lookup in any registry imports siftom's own registering modules and then runs every
installed plug-in once; a plug-in that fails is reported by ``siftom plugins`` (it does not
break the others).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import shutil
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from siftom.errors import BackendUnavailableError, SiftomError, unknown_name

_ALL: dict[str, Registry] = {}


def _import(target: str) -> Any:
    module, sep, attr = target.partition(":")
    if not sep or not module or not attr:
        raise SiftomError(f"entry point {target!r} must look like 'package.module:attr'")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class EntryStatus:
    """Whether a plug-in can be used here: name, summary and, when it cannot, why (``missing``)."""

    name: str
    summary: str
    missing: str | None = None

    @property
    def available(self) -> bool:
        return self.missing is None

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "summary": self.summary, "available": self.available,
                **({"missing": self.missing} if self.missing else {})}


@dataclass(frozen=True)
class Entry:
    """A registered plug-in.

    Attributes:
        kind: what it is ("ASR engine", "instruction likelihood", ...).
        name: its registry name (``pocketsphinx``, ``kitchen-v0``).
        entry_point: ``"module:attr"`` of the class or factory, imported on first use.
        summary: one line for ``--help`` and ``/healthz``.
        requires: Python modules that must be importable (checked without importing them).
        extra: the ``siftom[extra]`` that installs ``requires``.
        binaries: programs needed on the PATH (e.g. ``espeak-ng``); any one of them suffices.
        checker: optional ``"module:attr"`` of a function returning None or why it is unusable
            (for entries configured by the environment, e.g. an LLM endpoint).
        attrs: anything else callers need before construction (e.g. what a likelihood consumes).
    """

    kind: str
    name: str
    entry_point: str
    summary: str = ""
    requires: tuple[str, ...] = ()
    extra: str | None = None
    binaries: tuple[str, ...] = ()
    checker: str | None = None
    attrs: Mapping[str, Any] = field(default_factory=dict)

    def missing(self) -> str | None:
        """Why this entry cannot be used here, or None when it can. Imports nothing heavy."""
        lacking = [m for m in self.requires if importlib.util.find_spec(m.split(".")[0]) is None]
        if lacking:
            how = f'pip install "siftom[{self.extra}]"' if self.extra else f"pip install {' '.join(lacking)}"
            return f"the {self.kind} {self.name!r} needs {', '.join(lacking)}; install it with: {how}"
        if self.binaries and not any(shutil.which(b) for b in self.binaries):
            return (f"the {self.kind} {self.name!r} needs {' or '.join(self.binaries)} on the PATH; "
                    f"on Debian: sudo apt-get install -y {self.binaries[0]}")
        if self.checker:
            why = _import(self.checker)()
            return None if why is None else str(why)
        return None

    def check(self) -> Entry:
        """Raise BackendUnavailableError naming the fix when the entry cannot be used."""
        why = self.missing()
        if why:
            raise BackendUnavailableError(why)
        return self

    def load(self) -> Any:
        """Check, then import and return the class or factory."""
        self.check()
        return _import(self.entry_point)

    def make(self, **kwargs: Any) -> Any:
        """Check, import and construct with ``kwargs``."""
        return self.load()(**kwargs)

    def build(self, **kwargs: Any) -> Any:
        """Import and construct without the environment check: for callers that pass the
        configuration themselves (e.g. an explicit LLM endpoint), which the class validates."""
        return _import(self.entry_point)(**kwargs)

    def describe(self) -> EntryStatus:
        """Name, summary, whether it is available and, if not, why."""
        return EntryStatus(self.name, self.summary, self.missing() or None)


class Registry:
    """Names to entries for one kind of plug-in; unknown names suggest close matches."""

    def __init__(self, kind: str, *, default: str | None = None) -> None:
        if kind in _ALL:
            raise SiftomError(f"a registry of {kind!r} exists already; import it instead of making another")
        self.kind, self.default = kind, default
        self._entries: dict[str, Entry] = {}
        self._loaders: list[Callable[[], None]] = []
        _ALL[kind] = self

    def register(self, name: str, entry_point: str, **fields: Any) -> Entry:
        """Add an entry (see :class:`Entry` for the fields); a name registers once."""
        if name in self._entries:
            raise SiftomError(f"{self.kind} {name!r} is registered already; pick another name")
        entry = Entry(self.kind, name, entry_point, **fields)
        self._entries[name] = entry
        return entry

    def on_first_use(self, loader: Callable[[], None]) -> None:
        """Run ``loader`` (which registers more entries) before the first lookup."""
        self._loaders.append(loader)

    def _load(self) -> dict[str, Entry]:
        _load_builtins_and_plugins()
        while self._loaders:
            self._loaders.pop(0)()
        return self._entries

    def __contains__(self, name: object) -> bool:
        return name in self._load()

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._load())

    def names(self) -> tuple[str, ...]:
        """Registered names, the default first."""
        names = sorted(self._load())
        if self.default in names:
            names.remove(self.default)
            names.insert(0, self.default)
        return tuple(names)

    def entries(self) -> Mapping[str, Entry]:
        return MappingProxyType(self._load())

    def spec(self, name: str | None = None) -> Entry:
        """The entry for ``name`` (the default when None); UnknownNameError lists close names."""
        name = name if name is not None else self.default
        entries = self._load()
        if name not in entries:
            raise unknown_name(self.kind, str(name), entries)
        return entries[name]

    def check(self, name: str | None = None) -> Entry:
        """The entry, after checking that it can be used here (else BackendUnavailableError)."""
        return self.spec(name).check()

    def make(self, name: str | None = None, **kwargs: Any) -> Any:
        """Check, import and construct the entry ``name`` with ``kwargs``."""
        return self.spec(name).make(**kwargs)

    def available(self) -> tuple[str, ...]:
        """Names usable on this machine now."""
        return tuple(n for n in self.names() if self._entries[n].missing() is None)

    def describe(self) -> list[EntryStatus]:
        return [self._entries[n].describe() for n in self.names()]

    def help_line(self, default: str | None = None) -> str:
        """'a (default), b, c (not installed)' for --help texts.

        Args:
            default: the name to mark as the default, when a command's default is not the
                registry's (a setting's); "" marks none.
        """
        marked = self.default if default is None else default
        out = []
        for n in self.names():
            tag = " (default)" if n == marked else ""
            if self._entries[n].missing():
                tag += " (unavailable)"
            out.append(n + tag)
        return ", ".join(out)


def registries() -> Mapping[str, Registry]:
    """Every registry, by kind (import the modules that define them first: see ``load_all``)."""
    return MappingProxyType(_ALL)


# Modules whose import defines the built-in registries (and registers siftom's own entries).
_DEFINERS = (
    "siftom.scenarios.base",
    "siftom.speech.tts",
    "siftom.assist.decide",
    "siftom.likelihood.registry",
    "siftom.speech.asr.base",
    "siftom.backends.config",
)
PLUGIN_GROUP = "siftom.plugins"
_STATE = {"loaded": False}
_PLUGIN_ERRORS: dict[str, str] = {}
_PLUGINS: dict[str, str] = {}


def _load_builtins_and_plugins() -> None:
    """Once per process: import siftom's registering modules, then run every plug-in."""
    if _STATE["loaded"]:
        return
    _STATE["loaded"] = True  # set first: the modules and plug-ins below look names up too
    for module in _DEFINERS:
        importlib.import_module(module)
    for ep in importlib.metadata.entry_points(group=PLUGIN_GROUP):
        _PLUGINS[ep.name] = ep.value
        try:
            ep.load()()
        except Exception as exc:  # a broken plug-in must not break siftom or the other plug-ins
            _PLUGIN_ERRORS[ep.name] = f"{ep.value}: {type(exc).__name__}: {exc}"


def plugins() -> Mapping[str, str]:
    """Installed plug-in packages' entry points (name -> "module:function"), after loading them."""
    _load_builtins_and_plugins()
    return MappingProxyType(_PLUGINS)


def plugin_errors() -> Mapping[str, str]:
    """Plug-ins that failed to register, with why."""
    _load_builtins_and_plugins()
    return MappingProxyType(_PLUGIN_ERRORS)


def load_all() -> Mapping[str, Registry]:
    """Import every module that defines a built-in registry, run the plug-ins; return all by kind."""
    _load_builtins_and_plugins()
    return registries()
