"""The one place ports are opened (tracker.transport)."""

from __future__ import annotations

import socket

import pytest

from tracker.emulator import Gs232Controller, serve_tcp
from tracker.errors import RotatorIOError
from tracker.transport import open_port


def test_network_ports_send_small_requests_at_once():
    # W gets no reply, so the controller delays its ACK; with Nagle on, the C2 written next
    # would wait for it on every cycle.
    with serve_tcp(Gs232Controller("gs232b")) as server:
        port = open_port(server.url, timeout_s=0.5)
        try:
            sock = port._socket
            assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0
            port.write(b"C2\r")
            assert port.read_until(b"\n").startswith(b"AZ=")
        finally:
            port.close()


def test_open_failure_says_what_to_check():
    with pytest.raises(RotatorIOError, match="Check the device path or URL"):
        open_port("/dev/does-not-exist-tracker")
