"""Service subcommand: ``serve`` (``siftom.cli.bench_serve`` load-tests it)."""

from __future__ import annotations

import dataclasses
import socket
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from siftom.backends.cli_options import flags_given, llm_config, llm_options
from siftom.cli.records import pass_options
from siftom.cli.serve_checks import check_port as check_port
from siftom.cli.serve_checks import interruptible
from siftom.errors import missing_extra
from siftom.settings.environment import TOKEN, read
from siftom.speech.cli_options import whisper_model_option

if TYPE_CHECKING:
    from siftom.bench.runlock import RunLock

F = TypeVar("F", bound=Callable[..., Any])


def _need_serve_extra() -> None:
    for module, package in (("fastapi", "fastapi"), ("uvicorn", "uvicorn"), ("multipart", "python-multipart")):
        try:
            __import__(module)
        except ModuleNotFoundError:
            raise missing_extra("serve", package) from None


def resolve_token(host: str, token: str | None, token_file: Path | None, configured: str | None = None
                  ) -> tuple[str | None, bool]:
    """The server's token and whether it was made here: ``--token``, ``--token-file``,
    ``SIFTOM_TOKEN``, the setting ``service.token``, in that order; none of them and ``host``
    beyond loopback: a fresh one (``secrets.token_urlsafe``). Loopback without one: None.

    Raises:
        OptionsError: both flags, an unreadable or empty token file, an unusable token.
    """

    from siftom.errors import OptionsError
    from siftom.options import check_token
    from siftom.service.access import is_loopback, new_token

    if token is not None and token_file is not None:
        raise OptionsError("give the token once: --token or --token-file, not both")
    if token is not None:
        return check_token(token, "--token"), False
    if token_file is not None:
        try:
            text = token_file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise OptionsError(f"cannot read the token file {str(token_file)!r} ({type(exc).__name__}); give a "
                               "UTF-8 text file holding the token on one line") from None
        return check_token(text, f"the token file {str(token_file)!r}"), False
    env = read(TOKEN)
    if env is not None:
        return check_token(env, TOKEN), False
    if configured is not None:
        return configured, False
    if is_loopback(host):
        return None, False
    return new_token(), True


def ready_urls(host: str, port: int, token: str | None) -> list[str]:
    """The URLs to open: ``http://HOST:PORT/`` (with ``?token=`` when ``token``); for a wildcard
    host, this machine's name and loopback."""

    hosts = [host]
    if host in ("0.0.0.0", "::", ""):
        hosts = [socket.gethostname(), "127.0.0.1"]
    tail = f"?token={token}" if token else ""
    return [f"http://{f'[{h}]' if ':' in h else h}:{port}/{tail}" for h in hosts]


def bound_names(host: str) -> list[str]:
    """Host names the server is reached by because of where it listens: the bound host, or for a
    wildcard this machine's name (the printed URL uses it)."""

    from siftom.service.access import is_ip

    if host in ("0.0.0.0", "::", ""):
        name = socket.gethostname().lower()
        return [name] if "." in name else [name, f"{name}.local"]
    return [] if is_ip(host.strip("[]")) else [host.lower()]


def access_for(host: str, token: str | None, hosts: tuple[str, ...], origins: tuple[str, ...]) -> Any:
    """The :class:`~siftom.service.access.Access` of a server on ``host`` (bound names allowed);
    an OptionsError names a malformed --allow-host or --allow-origin."""
    from siftom.service.access import Access

    return Access(token=token, hosts=(*hosts, *bound_names(host)), origins=origins)


access_options = [
    click.option("--token", default=None,
                 help="the token every request must carry (Authorization: Bearer TOKEN, or ?token= in a page URL); "
                      "default: SIFTOM_TOKEN, then the setting service.token, then a fresh one printed at start "
                      "when --host is not loopback"),
    click.option("--token-file", type=click.Path(dir_okay=False, path_type=Path), default=None,
                 help="read the token from this file (keeps it out of the process list)"),
    click.option("--allow-host", "allow_host", multiple=True, metavar="NAME",
                 help="a Host name to answer to beyond localhost, IP addresses and --host (repeatable; "
                      "'*': any; others get 400, a guard against DNS rebinding)"),
    click.option("--allow-origin", "allow_origin", multiple=True, metavar="ORIGIN",
                 help="scheme://host[:port] of a page allowed to post and stream here beyond the server's own "
                      "(repeatable; others get 403)"),
]


def with_access_options(fn: F) -> F:
    """Add ``--token``, ``--token-file``, ``--allow-host`` and ``--allow-origin`` to a command."""
    for opt in reversed(access_options):
        fn = opt(fn)
    return fn


def announce(what: str, host: str, port: int, token: str | None, generated: bool, extra: str = "") -> None:
    """Print where the server listens, with the token's URL when this process made the token."""
    from siftom.service.access import is_loopback

    if not is_loopback(host):
        click.echo(f"note: listening on {host}: other machines can reach it; every request needs the token",
                   err=True)
    if token is not None and generated:
        urls = ready_urls(host, port, token)
        click.echo(f"siftom: {what} at {urls[0]}{extra}", err=True)
        for url in urls[1:]:
            click.echo(f"        or {url}", err=True)
        click.echo("        robots send the header: Authorization: Bearer " + token, err=True)
        return
    urls = ready_urls(host, port, None)
    given = " (with the token you gave: ?token=TOKEN or Authorization: Bearer TOKEN)" if token else ""
    click.echo(f"siftom: {what} at {urls[0]}{extra}{given}", err=True)


STOP_GRACE_S = 5  # on SIGTERM, requests and streams in flight get this long before they are cut


@contextmanager
def stopped_by_signals() -> Iterator[None]:
    """SIGTERM and SIGINT stop the server cleanly, also while it warms up: the ``finally``
    blocks inside stop the audio workers, close the stores and release the data folder's lock
    (its owner record removed); then the process ends by that signal, as an unhandled one
    would (exit status 128 + signal in a shell, a clean stop for systemd). uvicorn handles the
    signals while it serves and passes them on here when it has shut down (it swallows the
    KeyboardInterrupt that follows: the signal is remembered here)."""
    import signal
    import threading

    from siftom.bench.runlock import RunInterrupted

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []

    def handler(signum: int, frame: Any) -> None:
        if received:  # a second one while stopping: let the cleanup finish
            return
        received.append(signum)
        raise RunInterrupted(signum)

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    except KeyboardInterrupt:
        if not received:
            raise
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if received:
        signum = received[0]
        click.echo(f"siftom: stopped by {signal.Signals(signum).name}; the data folder is released", err=True)
        sys.stderr.flush()
        signal.signal(signum, signal.SIG_DFL)
        signal.raise_signal(signum)


def claim_data_dir(data_dir: str) -> RunLock:
    """Hold ``DATA_DIR/.siftom.lock`` for the life of this process: one server per data folder.

    Two servers on one folder would each cache sessions the other changes (answers from stale
    state, appends refused forever). The kernel drops the lock when the process dies, however
    it dies, so a restart after a crash is not refused.

    Raises:
        RunLockedError: another live process serves (or writes) the folder.
    """
    from siftom.bench.runlock import RunLock

    lock = RunLock(data_dir, fix="stop that server first, or give this one another --data-dir")
    lock.acquire()
    return lock


@dataclasses.dataclass(frozen=True)
class ServeOptions:
    """The ``siftom serve`` flags as one record."""

    host: str
    port: int
    data_dir: str | None
    max_sessions: int | None
    session_idle: float | None
    max_world_bytes: int | None
    max_world_items: int | None
    max_session_actions: int | None
    max_streams: int | None
    max_utterance: float | None
    stream_idle: float | None
    audio_workers: int | None
    header_timeout: float | None
    body_timeout: float | None
    config_file: Path | None
    trusted_proxy: tuple[str, ...]
    token: str | None
    token_file: Path | None
    allow_host: tuple[str, ...]
    allow_origin: tuple[str, ...]
    llm_backend: str | None
    llm_base_url: str | None
    llm_model: str | None


@click.command("serve")
@whisper_model_option
@click.option("--host", default="127.0.0.1", show_default=True, help="interface to listen on")
@click.option("--port", type=click.IntRange(1, 65535), default=8000, show_default=True, help="TCP port")
@click.option("--data-dir", type=click.Path(file_okay=False), default=None,
              help="the service's own folder (map cache, sessions.sqlite3); give the same folder after a "
                   "restart to continue the sessions; default: a fresh temporary folder")
@click.option("--max-sessions", type=click.IntRange(1, 1_000_000), default=None,
              help="sessions stored at once (429 above)")
@click.option("--session-idle", type=click.FloatRange(1, 365 * 86400), default=None,
              help="seconds without a change after which a session is deleted")
@click.option("--max-world-bytes", type=click.IntRange(1024, 64 * 2**20), default=None,
              help="largest world JSON in POST /v1/sessions (413 above)")
@click.option("--max-world-items", type=click.IntRange(1, 10_000), default=None,
              help="most objects a session's world may hold (422 above)")
@click.option("--max-session-actions", type=click.IntRange(1, 1_000_000), default=None,
              help="most actions one session may observe (422 above)")
@click.option("--max-streams", type=click.IntRange(1, 10_000), default=None,
              help="WS /v1/sessions/{id}/listen streams open at once (more are closed with 1013)")
@click.option("--max-utterance", type=click.FloatRange(1, 120), default=None,
              help="seconds of speech after which a streamed utterance is cut and answered")
@click.option("--stream-idle", type=click.FloatRange(0.1, 86400), default=None,
              help="seconds without a message after which a stream is closed (4408)")
@click.option("--audio-workers", type=click.IntRange(0, 64), default=None,
              help="worker processes scoring audio requests in parallel (0: in the request thread)")
@click.option("--header-timeout", type=click.FloatRange(0.1, 3600), default=None,
              help="seconds a client may take to send a request's headers (then 408, connection closed); "
                   "default 10")
@click.option("--body-timeout", type=click.FloatRange(0.1, 3600), default=None,
              help="seconds a client may take to send a request's body after its headers (then disconnected); "
                   "default 60")
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="a TOML settings file (default: SIFTOM_CONFIG); flags > SIFTOM_* > file > defaults")
@click.option("--trusted-proxy", "trusted_proxy", multiple=True, metavar="ADDR",
              help="the address (or network) of a reverse proxy whose X-Forwarded-For and X-Forwarded-Proto "
                   "are believed (repeatable; default: none, every client is its connection's address)")
@with_access_options
@llm_options
@pass_options(ServeOptions)
def serve_cmd(args: ServeOptions) -> None:
    """Serve the HTTP API and the web page (open http://HOST:PORT/).

    Beyond loopback every request needs a token (printed at start with a ready URL, or given with
    --token, --token-file or SIFTOM_TOKEN; docs/security.md). Unset limits come from the settings
    (``siftom config show``: sessions.*, service.*). The "llm" likelihood uses the --llm-* flags
    or SIFTOM_LLM_* (GET /healthz shows which).
    """
    _serve(args)


def _serve(opts: ServeOptions) -> None:
    """Run ``siftom serve`` with the flags in ``opts``."""
    interruptible()  # before the imports: a Ctrl-C while they load stops the server as one later does
    _need_serve_extra()
    import uvicorn

    from siftom.observer import Observer
    from siftom.private import private_umask
    from siftom.service.app import create_app
    from siftom.service.runtime import ServiceSettings
    from siftom.service.slow_clients import BODY_TIMEOUT_S, HEADER_TIMEOUT_S, deadline_protocol
    from siftom.settings import Settings

    flags: dict[str, object] = {
        "sessions.max_sessions": opts.max_sessions, "sessions.idle_s": opts.session_idle,
        "sessions.max_world_bytes": opts.max_world_bytes, "sessions.max_world_items": opts.max_world_items,
        "sessions.max_actions": opts.max_session_actions, "service.audio_workers": opts.audio_workers,
        "stream.max_streams": opts.max_streams, "stream.max_utterance_s": opts.max_utterance,
        "stream.max_idle_s": opts.stream_idle}
    if flags_given(opts.llm_backend, opts.llm_base_url, opts.llm_model):
        cfg = llm_config(opts.llm_backend, opts.llm_base_url, opts.llm_model)
        flags.update({"llm.backend": cfg.backend, "llm.base_url": cfg.base_url, "llm.model": cfg.model})
    loaded = Settings.load(opts.config_file, flags=flags)
    settings = loaded.service
    # a world of max_world_bytes must fit in a request body
    need = settings.sessions.max_world_bytes + 4096
    if settings.max_body_bytes < need:
        settings = dataclasses.replace(settings, max_body_bytes=max(ServiceSettings().max_body_bytes, need))
    from siftom.service.hosts import proxy_options

    proxy_headers, forwarded = proxy_options(opts.trusted_proxy)  # a malformed address: one line, before anything
    token, generated = resolve_token(opts.host, opts.token, opts.token_file, settings.token)
    access = access_for(opts.host, token, (*settings.allowed_hosts, *opts.allow_host),
                        (*settings.allowed_origins, *opts.allow_origin))
    settings = dataclasses.replace(settings, token=token, allowed_hosts=access.hosts, allowed_origins=access.origins)
    private_umask()  # sessions, ratings, maps: 0600 files in 0700 folders
    # the port first: in use, it is a one-line error before any model loads (or starts loading)
    check_port(opts.host, opts.port)
    with stopped_by_signals():
        lock, app = None, None
        try:
            lock = claim_data_dir(opts.data_dir) if opts.data_dir is not None else None
            announce("web page", opts.host, opts.port, token, generated, " , API schema at /openapi.json")
            # every request goes through one observer built from these settings (as siftom.infer does)
            observer = Observer(loaded, offered=settings.offered, max_audio_seconds=settings.max_audio_seconds,
                                decode_in_worker=True)  # pocketsphinx off the GIL: other requests keep going
            app = create_app(opts.data_dir, settings, observer)
            uvicorn.run(app, host=opts.host, port=opts.port, log_level="info",
                        timeout_graceful_shutdown=STOP_GRACE_S,
                        proxy_headers=proxy_headers, forwarded_allow_ips=forwarded,
                        http=deadline_protocol(opts.header_timeout or HEADER_TIMEOUT_S,
                                               opts.body_timeout or BODY_TIMEOUT_S))  # slow clients cut off
        finally:  # also on SIGTERM / SIGINT, during warm-up too: workers stopped, folder released
            if app is not None:
                app.state.runtime.close()
            if lock is not None:
                lock.release()


def register(root: click.Group) -> None:
    """Add ``serve`` to the root group."""
    root.add_command(serve_cmd)
