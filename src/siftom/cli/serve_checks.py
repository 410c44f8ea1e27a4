"""What ``siftom serve`` checks and sets before anything starts: the host and port it will bind,
and SIGINT stopping it while it loads."""

from __future__ import annotations

import errno
import socket


def interruptible() -> None:
    """Let SIGINT stop this process from now on, also when it was started with SIGINT ignored (a
    background job of a shell script is): the server takes SIGINT once it serves, so it takes it
    while it starts too, rather than ignoring it until then."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def check_port(host: str, port: int) -> None:
    """Bind ``host:port`` as the server will (every address the host resolves to, as asyncio
    binds them) and let go again, before anything else starts: a port in use is a one-line error
    at once, not a failure after the models began to load.

    A host that resolves to no address, or to one that is not this machine's, is refused the same
    way, before a token is made or printed.

    Raises:
        OptionsError: the host is no address here, the port is in use or needs privileges; the
            message names the host or port and the fix.
    """
    from siftom.errors import OptionsError

    fix = "give an address of this machine: 127.0.0.1 (this machine only), 0.0.0.0 (every interface) or one of its IPs"
    try:
        infos = socket.getaddrinfo(host or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (OSError, UnicodeError):
        raise OptionsError(f"--host {host!r} is not an IP address or a name this machine can resolve; {fix}") from None
    socks: list[socket.socket] = []
    try:
        for family, kind, proto, _name, addr in dict.fromkeys((i[0], i[1], i[2], "", i[4]) for i in infos):
            sock = socket.socket(family, kind, proto)
            socks.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6 and hasattr(socket, "IPPROTO_IPV6"):
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            sock.bind(addr)
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise OptionsError(f"port {port} on {host} is in use (another server, or a siftom serve still running); "
                               f"stop it, or give another port: --port {port + 1 if port < 65535 else 8000}") from None
        if exc.errno == errno.EACCES:
            raise OptionsError(f"port {port} on {host} needs privileges this user lacks; give a port above 1023: "
                               "--port 8000") from None
        if exc.errno in (errno.EADDRNOTAVAIL, errno.EINVAL, errno.EAFNOSUPPORT):
            raise OptionsError(f"--host {host!r} is not an address of this machine ({exc.strerror}); {fix}") from None
    finally:
        for sock in socks:
            sock.close()
