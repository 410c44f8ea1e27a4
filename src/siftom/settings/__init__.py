"""One settings object: every option, from a TOML file, ``SIFTOM_*`` variables and flags.

Precedence, highest first: **flags > environment > file > defaults**. A setting is named
``SECTION.FIELD``; each section is an existing option class, and its fields are the settings
(a field added to the class is a setting at once, with no code here):

=========  ==============================================  =====================================
section    option class                                    environment variable
=========  ==============================================  =====================================
infer      ``siftom.options.InferOptions`` (likelihood ...)  ``SIFTOM_INFER_LIKELIHOOD`` ...
model      ``siftom.options.ModelConfig``                  ``SIFTOM_MODEL_BETAS`` (comma list)
service    ``siftom.options.ServiceSettings``              ``SIFTOM_SERVICE_WORKERS`` ...
sessions   ``siftom.options.SessionLimits``                ``SIFTOM_SESSIONS_MAX_SESSIONS`` ...
stream     ``siftom.options.StreamLimits``                 ``SIFTOM_STREAM_MAX_STREAMS`` ...
llm        ``siftom.settings.llm.LLMConfig``               its own ``SIFTOM_LLM_*`` (docs/llm.md)
rules      the decision rules' options, ``[rules.ask-or-act]``  (file and flags only)
likelihoods  a likelihood's constructor options, ``[likelihoods.acoustic]``  (file and flags)
=========  ==============================================  =====================================

The file is ``--config FILE`` or ``SIFTOM_CONFIG``::

    [infer]
    likelihood = "acoustic"
    [model]
    betas = [0.5, 1.0, 2.0]
    [rules.ask-or-act]
    ask_cost = 1.5

An unknown section, key or rule option is an error naming it. ``siftom config show`` prints
every resolved value and where it came from.
"""

from __future__ import annotations

import dataclasses
import os
import tomllib
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from siftom.errors import SettingsError, SiftomError, unknown_name
from siftom.registry import load_all
from siftom.settings import environment

if TYPE_CHECKING:
    from siftom.options import (
        InferOptions,
        ModelConfig,
        ServiceSettings,
        SessionLimits,
        StreamLimits,
    )
    from siftom.settings.llm import LLMConfig

ENV_CONFIG = environment.CONFIG
ENV_PREFIX = environment.PREFIX


# section -> "module:class"; imported only when the section is used
SECTIONS: dict[str, str] = {
    "infer": "siftom.options:InferOptions",
    "model": "siftom.options:ModelConfig",
    "service": "siftom.options:ServiceSettings",
    "sessions": "siftom.options:SessionLimits",
    "stream": "siftom.options:StreamLimits",
    "llm": "siftom.settings.llm:LLMConfig",
}
# settings never shown (``siftom config show``, ``/healthz``)
SECRETS = {"service.token"}
# fields that hold other sections or derived state, not settings
_NOT_SETTINGS = {"service": {"llm", "llm_error", "sessions", "stream"}, "llm": set[str]()}
_LLM_ENV = {"backend": environment.LLM_BACKEND, "base_url": environment.LLM_BASE_URL,
            "model": environment.LLM_MODEL, "api_key": environment.LLM_API_KEY, "timeout_s": environment.LLM_TIMEOUT,
            "max_retries": environment.LLM_MAX_RETRIES, "cache_dir": environment.CACHE_DIR,
            "prompt": environment.LLM_PROMPT}


def _class(section: str) -> type:
    import importlib

    module, _, attr = SECTIONS[section].partition(":")
    cls: type = getattr(importlib.import_module(module), attr)
    return cls


def _section_fields(section: str) -> dict[str, Any]:
    """The settings of a section: field name -> type (from the option class's annotations)."""
    cls = _class(section)
    hints = typing.get_type_hints(cls)
    skip = _NOT_SETTINGS.get(section, set())
    return {f.name: hints[f.name] for f in dataclasses.fields(cls) if f.init and f.name not in skip}


def _defaults(section: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in dataclasses.fields(_class(section)):
        if f.default is not dataclasses.MISSING:
            out[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            out[f.name] = f.default_factory()
    return out


def _convert(key: str, value: Any, typ: Any) -> Any:
    """``value`` (a string from the environment or a flag, or a TOML value) as type ``typ``."""
    origin, args = typing.get_origin(typ), typing.get_args(typ)
    if origin in (typing.Union, types.UnionType):
        empty = value is None or (isinstance(value, str) and value.strip().lower() in ("", "none", "null"))
        if empty and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _convert(key, value, inner[0]) if len(inner) == 1 else value
    try:
        if origin is tuple:
            items = [s.strip() for s in value.split(",") if s.strip()] if isinstance(value, str) else list(value)
            inner_t = args[0] if args else str
            return tuple(_convert(key, v, inner_t) for v in items)
        if typ is bool:
            if isinstance(value, bool):
                return value
            low = str(value).strip().lower()
            if low in ("1", "true", "yes", "on"):
                return True
            if low in ("0", "false", "no", "off"):
                return False
            raise ValueError(value)
        if typ is int:
            if isinstance(value, bool):
                raise ValueError(value)
            return int(value)
        if typ is float:
            return float(value)
        if typ is str:
            if not isinstance(value, str):
                raise ValueError(value)
            return value
        if typ is Path:
            return Path(value)
    except (TypeError, ValueError):
        raise SettingsError(f"setting {key}: {value!r} is not a valid {getattr(typ, '__name__', typ)}") from None
    return value


def _read_file(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise SettingsError(f"{path}: no such settings file; give a TOML file (siftom config show --help)")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SettingsError(f"{path}: not valid TOML ({exc})") from None
    return data


def _likelihood_options(name: str) -> dict[str, Any]:
    """The keyword options of likelihood ``name``'s constructor: name -> type."""
    import inspect

    target = load_all()["instruction likelihood"].spec(name).load()
    init = vars(target).get("__init__", target) if isinstance(target, type) else target
    try:
        hints = typing.get_type_hints(init)
    except Exception:  # an annotation that does not resolve: take the values as given
        hints = {}
    params = inspect.signature(init).parameters
    return {k: hints.get(k, Any) for k, p in params.items()
            if k != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}


def _rule_options(rule: str) -> tuple[str, ...]:
    opts: tuple[str, ...] = tuple(load_all()["decision rule"].spec(rule).attrs.get("options", ()))
    return opts


def _put_file(file: Path, put: Callable[[str, str, Any, str], None], put_rule: Callable[[str, Any, str], None],
              put_likelihood: Callable[[str, Any, str], None]) -> None:
    """Put every value of a TOML settings file: its sections, ``[rules.X]`` and ``[likelihoods.X]``."""
    where = f"file {file}"
    for section, table in _read_file(file).items():
        if section == "rules" and isinstance(table, Mapping):
            for rule, opts in table.items():
                put_rule(rule, opts, where)
            continue
        if section == "likelihoods" and isinstance(table, Mapping):
            for lik, opts in table.items():
                put_likelihood(lik, opts, where)
            continue
        if not isinstance(table, Mapping):
            raise SettingsError(f"{file}: {section!r} must be a [section] table; sections: "
                                f"{', '.join([*SECTIONS, 'rules'])}")
        for k, v in table.items():
            put(section, k, v, where)


@dataclass(frozen=True)
class Settings:
    """Every option, resolved. Build with :meth:`load` (file, environment, flags).

    ``values[section][key]`` holds what was given (not the defaults) and ``sources`` says where
    each came from (``file PATH``, ``env NAME``, ``flag``). The sections are built on first use.
    """

    values: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)
    rules: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    likelihoods: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    @classmethod
    def load(cls, file: str | Path | None = None, env: Mapping[str, str] | None = None,
             flags: Mapping[str, Any] | None = None) -> Settings:
        """Resolve settings: ``flags`` ({"section.key": value}) > ``env`` > ``file`` > defaults.

        ``file`` defaults to ``SIFTOM_CONFIG`` (none when unset); ``env`` to ``os.environ``.
        """
        env = os.environ if env is None else env
        values: dict[str, dict[str, Any]] = {}
        sources: dict[str, str] = {}
        rules: dict[str, dict[str, Any]] = {}
        liks: dict[str, dict[str, Any]] = {}
        file = file if file is not None else (env.get(ENV_CONFIG) or None)

        def put(section: str, key: str, value: Any, source: str) -> None:
            if section not in SECTIONS:
                raise unknown_name("settings section", section, [*SECTIONS, "rules", "likelihoods"])
            known = _section_fields(section)
            if key not in known:
                raise SettingsError(str(unknown_name(f"setting in [{section}]", key, known)).rstrip(".")
                                    + f" (from {source})")
            values.setdefault(section, {})[key] = _convert(f"{section}.{key}", value, known[key])
            sources[f"{section}.{key}"] = source

        def put_rule(rule: str, opts: Any, source: str) -> None:
            if not isinstance(opts, Mapping):
                raise SettingsError(f"[rules.{rule}] must be a table of options (from {source})")
            takes = _rule_options(rule)
            for k, v in opts.items():
                if k not in takes:
                    raise SettingsError(str(unknown_name(f"option of decision rule {rule!r}", k, takes)).rstrip(".")
                                        + f" (from {source})")
                rules.setdefault(rule, {})[k] = v
                sources[f"rules.{rule}.{k}"] = source

        def put_likelihood(name: str, opts: Any, source: str) -> None:
            if not isinstance(opts, Mapping):
                raise SettingsError(f"[likelihoods.{name}] must be a table of options (from {source})")
            takes = _likelihood_options(name)
            for k, v in opts.items():
                if k not in takes:
                    raise SettingsError(str(unknown_name(f"option of likelihood {name!r}", k, takes)).rstrip(".")
                                        + f" (from {source})")
                typ = takes[k]
                liks.setdefault(name, {})[k] = v if typ is Any else _convert(f"likelihoods.{name}.{k}", v, typ)
                sources[f"likelihoods.{name}.{k}"] = source

        if file is not None:
            _put_file(Path(file), put, put_rule, put_likelihood)
        for name in sorted(env):
            if not name.startswith(ENV_PREFIX):
                continue
            rest = name[len(ENV_PREFIX):].lower()
            prefixed = next((s for s in SECTIONS if s != "llm" and rest.startswith(s + "_")), None)
            if prefixed is not None:
                put(prefixed, rest[len(prefixed) + 1:], env[name], f"env {name}")
            elif rest.startswith("llm_") or name == "SIFTOM_CACHE_DIR":
                for key, var in _LLM_ENV.items():
                    if var == name:
                        sources[f"llm.{key}"] = f"env {name}"
        for dotted, v in (flags or {}).items():
            if v is None:
                continue
            section, _, key = dotted.partition(".")
            if section == "rules":
                rule, _, opt = key.partition(".")
                put_rule(rule, {opt: v}, "flag")
            elif section == "likelihoods":
                lik, _, opt = key.partition(".")
                put_likelihood(lik, {opt: v}, "flag")
            else:
                put(section, key, v, "flag")
                if section == "llm":  # a flag beats the LLM's own environment variable
                    sources[dotted] = "flag"
        settings = cls(values, sources, rules, liks)
        settings.check()
        return settings

    def check(self) -> None:
        """Build every section that was given a value, so invalid values fail now."""
        for section in self.values:
            getattr(self, section)

    def _section(self, section: str, **extra: Any) -> Any:
        try:
            return _class(section)(**{**self.values.get(section, {}), **extra})
        except SiftomError as exc:
            given = ", ".join(f"{section}.{k} ({self.sources.get(f'{section}.{k}', '?')})"
                              for k in self.values.get(section, {}))
            raise SettingsError(f"{exc}" + (f" [settings given: {given}]" if given else "")) from None

    @cached_property
    def infer(self) -> InferOptions:
        """How ``siftom.infer`` hears and scores."""
        opts: InferOptions = self._section("infer")
        return opts

    @cached_property
    def model(self) -> ModelConfig:
        """The SIFToM model's options (mode, betas, priors ...)."""
        cfg: ModelConfig = self._section("model")
        return cfg

    @cached_property
    def sessions(self) -> SessionLimits:
        """The session API's limits."""
        lim: SessionLimits = self._section("sessions")
        return lim

    @cached_property
    def stream(self) -> StreamLimits:
        """The streaming endpoint's limits."""
        lim: StreamLimits = self._section("stream")
        return lim

    @cached_property
    def llm(self) -> LLMConfig | None:
        """The language model: file and flag values over the ``SIFTOM_LLM_*`` environment
        (flags beat the environment, the environment beats the file)."""
        from siftom.settings.llm import LLMConfig

        given = dict(self.values.get("llm", {}))
        over = {k: v for k, v in given.items() if not self.sources.get(f"llm.{k}", "").startswith("env")}
        return LLMConfig.from_env(None, **over)

    @cached_property
    def service(self) -> ServiceSettings:
        """The HTTP service's options (its sessions and LLM come from those sections)."""
        try:
            llm = self.llm
        except SiftomError:  # an invalid LLM environment: the service says why in /healthz
            llm = None
        svc: ServiceSettings = self._section("service", sessions=self.sessions, stream=self.stream,
                                             **({"llm": llm} if llm is not None else {}))
        return svc

    def likelihood_options(self, name: str) -> dict[str, object]:
        """The constructor options given for likelihood ``name`` (checked at load)."""
        return dict(self.likelihoods.get(name, {}))

    def rule_options(self, rule: str) -> dict[str, object]:
        """The options given for decision rule ``rule`` (checked at load)."""
        return dict(self.rules.get(rule, {}))

    def show(self) -> list[tuple[str, Any, str]]:
        """(``section.key``, resolved value, source) for every setting, defaults included."""
        out: list[tuple[str, Any, str]] = []
        for section in SECTIONS:
            if section == "llm":
                try:
                    resolved = dataclasses.asdict(self.llm) if self.llm is not None else {}
                except SiftomError as exc:
                    out.append(("llm", f"invalid: {exc}", "env"))
                    continue
                for k, v in resolved.items():
                    shown = "***" if k == "api_key" and v else v
                    out.append((f"llm.{k}", shown, self.sources.get(f"llm.{k}", "default")))
                continue
            given = self.values.get(section, {})
            defaults = _defaults(section)
            for k in _section_fields(section):
                value = given.get(k, defaults.get(k))
                if f"{section}.{k}" in SECRETS and value:
                    value = "***"
                out.append((f"{section}.{k}", value, self.sources.get(f"{section}.{k}", "default")))
        for rule, opts in sorted(self.rules.items()):
            for k, v in opts.items():
                out.append((f"rules.{rule}.{k}", v, self.sources.get(f"rules.{rule}.{k}", "file")))
        for lik, opts in sorted(self.likelihoods.items()):
            for k, v in opts.items():
                out.append((f"likelihoods.{lik}.{k}", v, self.sources.get(f"likelihoods.{lik}.{k}", "file")))
        return out
