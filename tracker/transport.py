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

import ipaddress
import socket
import urllib.parse
from typing import Any, TypeAlias

import serial

from tracker.clock import Clock, SystemClock
from tracker.errors import ConfigError, RotatorIOError

# Serial rates a port can be asked for: the slowest standard rate up to the fastest Linux
# termios knows (B4000000); pyserial passes anything else through to a failing ioctl.
BAUD_MIN = 50
BAUD_MAX = 4_000_000
_NETWORK_SCHEMES = ("socket", "rfc2217")


def check_baud(baud: object, where: str = "baud") -> int:
    """``baud`` as an int if it is a serial rate a port can take, else ConfigError naming
    ``where`` (the flag or config key it came from)."""
    if isinstance(baud, bool) or not isinstance(baud, int) or not BAUD_MIN <= baud <= BAUD_MAX:
        raise ConfigError(f"{where} {baud} is invalid; give a baud rate (a whole number) from "
                          f"{BAUD_MIN} to {BAUD_MAX:,}, such as 9600 (the controller's setting)")
    return baud


def check_url(url: str) -> None:
    """Refuse a network URL without a valid ``HOST:PORT`` (pyserial's own messages for these
    are cryptic); device paths and other schemes are left to pyserial."""
    scheme, sep, _rest = url.partition("://")
    if not sep or scheme.lower() not in _NETWORK_SCHEMES:
        return
    parts = urllib.parse.urlsplit(url)
    example = f"{scheme}://127.0.0.1:4533"
    try:
        port = parts.port
    except ValueError:
        port_text = parts.netloc.rpartition(":")[2]
        raise ConfigError(f"{url!r}: port {port_text} is not a TCP port (1-65535); write "
                          f"{example}") from None
    if not parts.hostname:
        raise ConfigError(f"{url!r} names no host; write {example}")
    if port is None:
        raise ConfigError(f"{url!r} names no port; write {scheme}://{parts.hostname}:PORT, "
                          f"e.g. {example}")
    if not 1 <= port <= 65535:
        raise ConfigError(f"{url!r}: port {port} is not a TCP port (1-65535); write {example}")

# A pyserial port, or a port-like test double (read, write, flush, close, in_waiting,
# reset_input_buffer, timeout). pyserial ships no type information, so this is Any.
Port: TypeAlias = Any

HANDLERS_PACKAGE = "tracker.serial_handlers"
if HANDLERS_PACKAGE not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append(HANDLERS_PACKAGE)

_REAL_TIME = SystemClock()

try:
    import termios

    # A tty that goes away while pyserial sets it up (a pty whose other end closes, a USB
    # adapter unplugged) fails in termios, whose error is not an OSError.
    _TTY_ERRORS: tuple[type[Exception], ...] = (termios.error,)
except ImportError:     # Windows
    _TTY_ERRORS = ()


def is_emulated(url: str) -> bool:
    """True for an ``emu://`` URL (an in-process emulator)."""
    return str(url).lower().startswith("emu://")


def open_port(url: str, baudrate: int = 9600, timeout_s: float = 1.0,
              write_timeout_s: float | None = 2.0, rtscts: bool = False,
              clock: Clock | None = None, **kwargs: Any) -> Port:
    """Open ``url`` with :func:`serial.serial_for_url`; raises :class:`RotatorIOError`, or
    :class:`ConfigError` for a malformed network URL or an impossible baud rate.

    ``clock``: the time an ``emu://`` controller runs on (ignored for real ports, which run
    on real time), normally the caller's simulation clock so both share one timeline."""
    if clock is not None and is_emulated(url):
        kwargs["clock"] = clock
    check_url(url)
    check_baud(baudrate, "baud rate")
    try:
        port = serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s,
                                     write_timeout=write_timeout_s, rtscts=rtscts, **kwargs)
    except (serial.SerialException, OSError, ValueError, OverflowError, *_TTY_ERRORS) as e:
        raise RotatorIOError(f"cannot open port {url!r}: {e}. Check the device path or URL "
                             f"(e.g. /dev/ttyUSB0, COM3, socket://127.0.0.1:4533, "
                             f"emu://gs232b)") from e
    _no_delay(port)
    _close_without_linger(port)
    return port


def _close_without_linger(port: Port) -> None:
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


def _no_delay(port: Port) -> None:
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


def io_clock(port: Port) -> Clock:
    """The clock a port's reads and writes take time on: the emulator's clock for
    ``emu://``, real time for every other port (and for port-like test doubles)."""
    clock = getattr(port, "clock", None)
    return clock if isinstance(clock, Clock) else _REAL_TIME


def is_loopback(host: str) -> bool:
    """True if ``host`` is reachable from this machine only (127.0.0.0/8, ::1,
    ``localhost``); False for any other address, the wildcard ("", 0.0.0.0, ::) and names
    that would need a lookup."""
    name = host.strip().strip("[]").lower()
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False
