"""Which ``Host`` names and ``Origin`` values a siftom server answers to (docs/security.md):
:class:`Access` holds them with the token; the helpers parse and check the names."""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass

from siftom.errors import OptionsError
from siftom.options import check_token

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    host = host.strip().strip("[]").lower()
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def split_host(value: str) -> tuple[str, str]:
    """``Host``-header value -> (host name lowercased without brackets or a final dot, port or '')."""
    value = value.strip().lower()
    if value.startswith("["):
        host, _, rest = value[1:].partition("]")
        return host, rest[1:] if rest.startswith(":") else ""
    host, sep, port = value.rpartition(":")
    if sep and port.isdigit() and ":" not in host:
        return host.rstrip("."), port
    return value.rstrip("."), ""


def is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


DEFAULT_PORTS = {"http": "80", "https": "443", "ws": "80", "wss": "443"}


def normal_origin(origin: str) -> str | None:
    """``scheme://host[:port]`` lowercased, the scheme's default port left out; None if malformed."""
    scheme, sep, rest = origin.strip().lower().partition("://")
    if not sep or scheme not in DEFAULT_PORTS or not rest or "/" in rest:
        return None
    host, port = split_host(rest)
    if not host:
        return None
    shown = f"[{host}]" if ":" in host else host
    return f"{scheme}://{shown}" + (f":{port}" if port and port != DEFAULT_PORTS[scheme] else "")


def check_host_name(name: str) -> str:
    """A name for ``--allow-host`` (``*`` for any), lowercased; an OptionsError when malformed."""
    host = name.strip().lower().rstrip(".")
    if host == "*":
        return host
    host = host.strip("[]")
    if not host or any(ch in host for ch in "/ @?#") or (":" in host and not is_ip(host)):
        raise OptionsError(f"--allow-host {name!r}: give a host name or address without scheme or port, "
                           "e.g. --allow-host robot-hub.local")
    return host


def check_origin(origin: str) -> str:
    """An origin for ``--allow-origin`` (``*`` for any), normalised; an OptionsError when malformed."""
    if origin.strip() == "*":
        return "*"
    got = normal_origin(origin)
    if got is None:
        raise OptionsError(f"--allow-origin {origin!r}: give scheme://host[:port] with no path, "
                           "e.g. --allow-origin https://robot-hub.example")
    return got


@dataclass(frozen=True)
class Access:
    """What a server checks (see module doc).

    Attributes:
        token: the token every request must carry; None: none asked for.
        hosts: ``Host`` names accepted beyond the loopback names and IP addresses (``*``: any).
        origins: ``Origin`` values accepted beyond the server's own (``*``: any).
    """

    token: str | None = None
    hosts: tuple[str, ...] = ()
    origins: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.token is not None:
            object.__setattr__(self, "token", check_token(self.token))
        object.__setattr__(self, "hosts", tuple(check_host_name(h) for h in self.hosts))
        object.__setattr__(self, "origins", tuple(check_origin(o) for o in self.origins))

    def host_allowed(self, host_header: str | None) -> bool:
        if "*" in self.hosts:
            return True
        if not host_header:
            return False
        host, _ = split_host(host_header)
        return host in LOOPBACK_NAMES or is_ip(host) or host in self.hosts

    def origin_allowed(self, origin: str, host_header: str | None, scheme: str) -> bool:
        """An Origin header is this server's own (same host and port as the Host header) or allowed."""
        if "*" in self.origins:
            return True
        got = normal_origin(origin)
        if got is None:  # "null" (a sandboxed page, a file) or garbage
            return False
        if got in self.origins:
            return True
        if not host_header:
            return False
        o_scheme, _, o_rest = got.partition("://")
        o_host, o_port = split_host(o_rest)
        h_host, h_port = split_host(host_header)
        # the scheme may differ behind a proxy that ends TLS: compare host and port
        o_port = o_port or DEFAULT_PORTS[o_scheme]
        h_port = h_port or DEFAULT_PORTS.get(o_scheme, DEFAULT_PORTS.get(scheme, "80"))
        return (o_host, o_port) == (h_host, h_port)


def check_proxy(value: str) -> str:
    """A ``--trusted-proxy`` value: an IP address or network (``127.0.0.1``, ``10.0.0.0/8``)."""
    text = value.strip()
    try:
        return str(ipaddress.ip_network(text, strict=False))
    except ValueError:
        raise OptionsError(f"--trusted-proxy {value!r} is not an IP address or network; give the address the "
                           "reverse proxy connects from, e.g. --trusted-proxy 127.0.0.1") from None


def proxy_options(trusted: tuple[str, ...] = ()) -> tuple[bool, list[str] | None]:
    """uvicorn's ``proxy_headers`` and ``forwarded_allow_ips``: ``X-Forwarded-For`` and
    ``X-Forwarded-Proto`` are read only from a peer in ``trusted`` (none by default), so a client
    cannot choose the address its wrong tokens are counted against, nor pass as another client
    (docs/security.md)."""
    nets = [check_proxy(t) for t in trusted]
    return bool(nets), nets or None
