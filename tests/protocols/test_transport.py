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


def test_a_tty_lost_while_it_is_set_up_is_an_open_failure(monkeypatch):
    # pyserial flushes a tty it has just opened; if the device went away in between (an
    # emulator's pty closing, a USB adapter pulled), termios raises its own error, which
    # must read as a port that cannot be opened, not a traceback.
    termios = pytest.importorskip("termios")

    def gone(*_args, **_kwargs):
        raise termios.error(5, "Input/output error")

    monkeypatch.setattr("tracker.transport.serial.serial_for_url", gone)
    with pytest.raises(RotatorIOError, match=r"cannot open port.*Input/output error"):
        open_port("/dev/ttyUSB9")


def test_closing_a_network_port_does_not_linger(monkeypatch):
    # pyserial's socket:// close() sleeps 0.3 s "for quick reconnects"; every reconnect and
    # every TCP test paid it. Closing must still shut the socket and free the server.
    from types import SimpleNamespace

    import serial.urlhandler.protocol_socket as protocol_socket
    from _gs232_helpers import wait_until

    slept: list[float] = []       # the handler's only use of its time module is that sleep
    monkeypatch.setattr(protocol_socket, "time", SimpleNamespace(sleep=slept.append))
    with serve_tcp(Gs232Controller("gs232b")) as server:
        port = open_port(server.url, timeout_s=0.5)
        sock = port._socket
        assert wait_until(lambda: server.connections == 1, 2)
        port.close()
        assert slept == [] and not port.is_open and sock.fileno() == -1
        assert wait_until(lambda: server.connections == 0, 2)
        port.close()                       # a second close is harmless
        with open_port(server.url, timeout_s=0.5) as again:     # the next client is served
            again.write(b"C2\r")
            assert again.read_until(b"\n").startswith(b"AZ=")
