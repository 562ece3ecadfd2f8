"""Is there a Dask scheduler at this address? Answered within seconds, before a client connects.

``distributed.Client`` given the address of something else waits forever (an HTTP server that
says nothing until asked) or reads an HTTP answer as a frame length and tries to allocate
exabytes (a proxy answering 404). A Dask server speaks first: on accepting a TCP connection it
writes its handshake, an 8-byte little-endian message length followed by frames whose msgpack
body names ``compression`` and ``python`` (distributed's ``comm.core`` handshake). So a socket
that sends nothing within the timeout, or sends anything else, is not a Dask scheduler.
"""

from __future__ import annotations

import socket
import struct

from dempath.errors import DempathError

MAX_HANDSHAKE_BYTES = 1 << 16  # a handshake is about 60 bytes; more is another protocol
HANDSHAKE_KEYS = (b'compression', b'python')


class SchedulerProbeError(DempathError):
    """The address does not answer as a Dask scheduler."""


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of ``tcp://host:port`` or ``host:port``; None for other transports."""
    scheme, sep, rest = address.partition('://')
    if sep and scheme != 'tcp':
        return None
    rest = rest if sep else address
    host, _, port = rest.rpartition(':')
    if not host or not port.isdigit():
        msg = f'{address}: not a scheduler address (expected tcp://HOST:PORT)'
        raise SchedulerProbeError(msg)
    return host.strip('[]'), int(port)


def _read(sock: socket.socket, n: int) -> bytes:
    data = b''
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            break
        data += chunk
    return data


def _more(sock: socket.socket) -> bytes:
    """Up to 64 more bytes already sent (to name another protocol's answer), else nothing."""
    sock.settimeout(0.2)
    try:
        return sock.recv(64)
    except OSError:
        return b''


def check_dask_scheduler(address: str, timeout_s: float = 5.0) -> None:
    """Raise unless a Dask server answers at ``address`` with its handshake within the timeout.

    Addresses of other transports (``tls://``, ``ucx://``, ``inproc://``) are not probed.

    Raises:
        SchedulerProbeError: One line naming the address and what answered (nothing, a
            refused connection, or the first bytes of another protocol).
    """
    target = _host_port(address)
    if target is None:
        return
    try:
        with socket.create_connection(target, timeout=timeout_s) as sock:
            sock.settimeout(timeout_s)
            head = _read(sock, 8)
            size = struct.unpack('<Q', head)[0] if len(head) == 8 else 0
            body = _read(sock, size) if 0 < size <= MAX_HANDSHAKE_BYTES else _more(sock)
    except TimeoutError:
        msg = (f'{address}: not a Dask scheduler (no handshake within {timeout_s:g} s; an HTTP '
               'or other server that waits to be asked?)')
        raise SchedulerProbeError(msg) from None
    except OSError as err:
        msg = f'{address}: cannot reach the Dask scheduler ({err.strerror or err})'
        raise SchedulerProbeError(msg) from None
    if not all(key in body for key in HANDSHAKE_KEYS):
        seen = (head + body)[:60].decode('ascii', 'replace').splitlines()
        msg = (f'{address}: not a Dask scheduler (it answered {seen[0] if seen else "nothing"!r}'
               ' instead of a Dask handshake)')
        raise SchedulerProbeError(msg)


__all__ = ['SchedulerProbeError', 'check_dask_scheduler']
