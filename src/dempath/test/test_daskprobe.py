"""The Dask scheduler probe: something else at the address is one clear error, at once."""

from __future__ import annotations

import http.server
import socket
import threading
from collections.abc import Iterator

import pytest

from dempath.daskprobe import SchedulerProbeError, check_dask_scheduler


@pytest.fixture
def http_server() -> Iterator[str]:
    """A plain HTTP server (it says nothing until asked): tcp://127.0.0.1:PORT."""
    server = http.server.ThreadingHTTPServer(('127.0.0.1', 0),
                                             http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield f'tcp://127.0.0.1:{server.server_address[1]}'
    finally:
        server.shutdown()
        server.server_close()


@pytest.fixture
def talking_proxy() -> Iterator[str]:
    """A server that answers every connection with an HTTP 404 straight away."""
    listener = socket.create_server(('127.0.0.1', 0))

    def serve() -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b'HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\n\r\n')

    threading.Thread(target=serve, daemon=True).start()
    try:
        yield f'127.0.0.1:{listener.getsockname()[1]}'
    finally:
        listener.close()


def test_http_server_is_not_a_scheduler(http_server: str) -> None:
    """A silent HTTP server: refused after the timeout (the Dask client used to hang)."""
    with pytest.raises(SchedulerProbeError, match=r'not a Dask scheduler .no handshake'):
        check_dask_scheduler(http_server, timeout_s=0.5)


def test_proxy_answering_404_is_not_a_scheduler(talking_proxy: str) -> None:
    """A 404 answer is named (the client used to read it as a frame length: 3.07 EiB)."""
    with pytest.raises(SchedulerProbeError, match=r"answered 'HTTP/1\.1 404 Not Found'"):
        check_dask_scheduler(talking_proxy, timeout_s=2.0)


def test_refused_and_malformed_addresses() -> None:
    """Nobody listening, or no port: one line naming the address."""
    with socket.create_server(('127.0.0.1', 0)) as s:
        port = s.getsockname()[1]
    with pytest.raises(SchedulerProbeError, match=f'127.0.0.1:{port}: cannot reach'):
        check_dask_scheduler(f'tcp://127.0.0.1:{port}', timeout_s=1.0)
    with pytest.raises(SchedulerProbeError, match='expected tcp://HOST:PORT'):
        check_dask_scheduler('tcp://somewhere')
    check_dask_scheduler('inproc://192.0.2.2/1/1')  # other transports are not probed
