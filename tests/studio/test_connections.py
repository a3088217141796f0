"""Half-open connections to a real studio server (uvicorn on a free port) are dropped after the
header timeout, while a connection that sends its request is answered."""

from __future__ import annotations

import socket

import pytest
from studio_helpers import serving

from pencilbot.studio import connections

MANY = 60


@pytest.fixture
def running(monkeypatch, tmp_path):
    monkeypatch.setattr(connections, "HEADER_TIMEOUT", 1.0)
    monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(tmp_path))
    from pencilbot.studio.server import prepare

    made = prepare(None, listen_port=0)
    thread = serving(made)
    yield made
    made.stop()
    thread.join(timeout=10)


def closed_by_server(sock: socket.socket) -> bool:
    """Whether the server closes ``sock`` within a few seconds (EOF or reset; what an earlier
    answer left unread is read past)."""
    sock.settimeout(connections.HEADER_TIMEOUT + 5)
    try:
        while sock.recv(65536):
            pass
        return True
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False


def test_half_open_connections_are_dropped_after_the_header_timeout(running):
    port = running.sock.getsockname()[1]
    silent, partial = [], []
    for k in range(MANY):
        sock = socket.create_connection(("127.0.0.1", port))
        if k % 2:
            sock.sendall(b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n" % port)  # the head never ends
            partial.append(sock)
        else:
            silent.append(sock)
    kept_alive = socket.create_connection(("127.0.0.1", port))  # one request, then a second begun and left
    kept_alive.sendall(b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n\r\n" % port)
    kept_alive.settimeout(10)
    assert kept_alive.recv(65536).startswith(b"HTTP/1.1 200")
    kept_alive.sendall(b"GET /api/state HTTP/1.1\r\n")
    try:
        assert all(closed_by_server(sock) for sock in silent), "a silent connection is held"
        assert all(closed_by_server(sock) for sock in partial), (
            "a connection sending half a request head is held"
        )
        assert closed_by_server(kept_alive), "a kept-alive connection that began a second head is held"
    finally:
        for sock in [*silent, *partial, kept_alive]:
            sock.close()
    with socket.create_connection(("127.0.0.1", port)) as sock:  # the server still answers
        sock.sendall(b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n\r\n" % port)
        sock.settimeout(10)
        assert sock.recv(65536).startswith(b"HTTP/1.1 200")
