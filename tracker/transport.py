"""The one place the project opens ports.

Every driver takes an already-open, port-like object; this function makes one from any
pyserial URL: ``/dev/ttyUSB0``, ``COM3``, ``socket://127.0.0.1:4533``, ``rfc2217://...``,
``spy://...``, and this project's ``emu://PROFILE?rotator=NAME`` (an emulated controller in
this process, see :mod:`tracker.emulator.virtual`). pyserial errors are translated here, at
the boundary.

:func:`io_clock` is the time a port's I/O runs on: drivers measure read deadlines and pacing
on it, never on a simulation clock that may run 100x faster than the wire.
"""

from __future__ import annotations

import socket

import serial

from tracker.clock import Clock, SystemClock
from tracker.errors import RotatorIOError

HANDLERS_PACKAGE = "tracker.serial_handlers"
if HANDLERS_PACKAGE not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append(HANDLERS_PACKAGE)

_REAL_TIME = SystemClock()


def is_emulated(url: str) -> bool:
    """True for an ``emu://`` URL (an in-process emulator)."""
    return str(url).lower().startswith("emu://")


def open_port(url: str, baudrate: int = 9600, timeout_s: float = 1.0,
              write_timeout_s: float | None = 2.0, rtscts: bool = False,
              clock: Clock | None = None, **kwargs):
    """Open ``url`` with :func:`serial.serial_for_url`; raises :class:`RotatorIOError`.

    ``clock``: the time an ``emu://`` controller runs on (ignored for real ports, which run
    on real time), normally the caller's simulation clock so both share one timeline."""
    if clock is not None and is_emulated(url):
        kwargs["clock"] = clock
    try:
        port = serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s,
                                     write_timeout=write_timeout_s, rtscts=rtscts, **kwargs)
    except (serial.SerialException, OSError, ValueError) as e:
        raise RotatorIOError(f"cannot open port {url!r}: {e}. Check the device path or URL "
                             f"(e.g. /dev/ttyUSB0, COM3, socket://127.0.0.1:4533, "
                             f"emu://gs232b)") from e
    _no_delay(port)
    return port


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


def io_clock(port) -> Clock:
    """The clock a port's reads and writes take time on: the emulator's clock for
    ``emu://``, real time for every other port (and for port-like test doubles)."""
    clock = getattr(port, "clock", None)
    return clock if isinstance(clock, Clock) else _REAL_TIME


def emu_clock(url: str) -> Clock | None:
    """The clock of the emulator bench an ``emu://NAME`` URL names (None for anything else):
    code that opens such a port later runs its own timing on that clock."""
    if not is_emulated(url):
        return None
    from tracker.emulator.virtual import clock_of

    return clock_of(url)
