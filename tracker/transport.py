"""The one place the project opens ports.

Every driver takes an already-open, port-like object; this function makes one from any
pyserial URL: ``/dev/ttyUSB0``, ``COM3``, ``socket://127.0.0.1:4533``, ``rfc2217://...``,
``spy://...``. pyserial errors are translated here, at the boundary.
"""

from __future__ import annotations

import socket

import serial

from tracker.errors import RotatorIOError


def open_port(url: str, baudrate: int = 9600, timeout_s: float = 1.0,
              write_timeout_s: float | None = 2.0, rtscts: bool = False, **kwargs):
    """Open ``url`` with :func:`serial.serial_for_url`; raises :class:`RotatorIOError`."""
    try:
        port = serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s,
                                     write_timeout=write_timeout_s, rtscts=rtscts, **kwargs)
    except (serial.SerialException, OSError, ValueError) as e:
        raise RotatorIOError(f"cannot open port {url!r}: {e}. Check the device path or URL "
                             f"(e.g. /dev/ttyUSB0, COM3, socket://127.0.0.1:4533)") from e
    _no_delay(port)
    _close_without_linger(port)
    return port


def _close_without_linger(port) -> None:
    """Make a ``socket://`` port's ``close()`` return at once.

    pyserial's socket handler sleeps 0.3 s after closing "in case of quick reconnects"; the
    drivers, the emulator and rotctld all accept a new connection right away, so the sleep
    only delays every reconnect (and every test over TCP). The replacement does what the
    original does minus the sleep: shut the socket down, close it, mark the port closed.
    """
    from serial.urlhandler.protocol_socket import Serial as SocketSerial

    if not isinstance(port, SocketSerial):
        return

    def close() -> None:
        sock, port._socket = port._socket, None
        if sock is not None:
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass    # the peer already went away
            sock.close()
        port.is_open = False

    port.close = close


def _no_delay(port) -> None:
    """Turn off Nagle on a network port (socket://, rfc2217://).

    A set command such as ``W`` gets no reply, so the peer delays its ACK; with Nagle on, the
    query written right after it (``C2``) then waits for that ACK, 40-200 ms per cycle. pyserial
    has no public switch for this, so reach its socket where there is one.
    """
    sock = getattr(port, "_socket", None)
    if sock is None:
        return
    try:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError:
        pass    # not a TCP socket; nothing to tune
