"""Byte I/O under every driver: one port, one request at a time.

:class:`ByteLink` is the only place a driver touches its port: paced writes, reads bounded on
the port's own time, the input flushed before a request, and pyserial/OS errors turned into
the project's typed errors (:class:`PortLostError`, :class:`RotatorTimeout`). Each protocol
module frames and parses the bytes itself (:mod:`tracker.protocols.framing` for lines).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

import serial

from tracker.clock import Clock, SystemClock
from tracker.errors import PortLostError, RotatorTimeout
from tracker.protocols.base import RotatorDriver
from tracker.transport import Port, io_clock

T = TypeVar("T")
D = TypeVar("D")

try:  # tcflush/tcsetattr on a vanished tty raise termios.error, which is not an OSError
    import termios

    PORT_ERRORS: tuple[type[BaseException], ...] = (serial.SerialException, OSError,
                                                    termios.error)
except ImportError:  # Windows
    PORT_ERRORS = (serial.SerialException, OSError)



class ByteLink:
    """One port, one request at a time: paced writes, bounded reads, errors translated.

    Every read is bounded by a deadline on the port's time
    (:func:`tracker.transport.io_clock`, real time for a real port, never a faster simulation
    clock); pyserial/OS errors become
    :class:`PortLostError`, write timeouts :class:`RotatorTimeout`.
    """

    def __init__(self, port: Port, clock: Clock | None = None, pace_cmd_s: float = 0.0,
                 pace_char_s: float = 0.0):
        self.port = port
        self.clock = clock or SystemClock()     # the caller's (simulation) time
        self.io_clock = io_clock(port)          # deadlines and pacing: the wire's time
        self.pace_cmd_s = float(pace_cmd_s)     # at least this between two writes
        self.pace_char_s = float(pace_char_s)   # and this between bytes (0: a write at once)
        self.lock = threading.RLock()
        self.closed = False
        self._last_write = -1e9

    @contextmanager
    def io(self, what: str) -> Iterator[None]:
        if self.closed:
            raise PortLostError(f"{what}: the port is closed")
        try:
            yield
        except serial.SerialTimeoutException as e:
            raise RotatorTimeout(f"{what}: write timed out (flow control holding? cable?)") from e
        except PORT_ERRORS as e:
            raise PortLostError(f"{what}: port lost: {e}") from e

    def write(self, data: bytes) -> None:
        wait = self._last_write + self.pace_cmd_s - self.io_clock.monotonic()
        if wait > 0:
            self.io_clock.sleep(wait)
        with self.io(f"writing {data!r}"):
            if self.pace_char_s > 0:
                self._write_paced(data)
            else:
                self.port.write(data)
                self.port.flush()
        self._last_write = self.io_clock.monotonic()

    def _write_paced(self, data: bytes) -> None:
        """One byte at a time, each followed by a wait until ``start + bytes_sent *
        pace_char_s`` on the port's clock.

        A running deadline rather than a sleep of ``pace_char_s`` per byte: a real sleep
        overshoots by a fraction of a millisecond, and over a long table line (1900 pairs at
        9600 Bd: ~19,000 bytes) those would add up to seconds."""
        start = self.io_clock.monotonic()
        for i in range(len(data)):
            self.port.write(data[i:i + 1])
            self.port.flush()
            wait = start + (i + 1) * self.pace_char_s - self.io_clock.monotonic()
            if wait > 0:
                self.io_clock.sleep(wait)

    def flush_input(self) -> None:
        with self.io("flushing input"):
            self.port.reset_input_buffer()

    def read_some(self, remaining_s: float) -> bytes:
        with self.io("reading"):
            self.port.timeout = max(0.001, min(remaining_s, 0.05))
            n = self.port.in_waiting
            return self.port.read(n if n > 0 else 1)

    def read_until(self, done: Callable[[bytes], T | None],
                   timeout_s: float) -> tuple[bytes, T | None]:
        """Read until ``done(buffer)`` is truthy (returns ``(buffer, result)``) or the timeout
        (returns ``(buffer, None)``)."""
        buf = bytearray()
        deadline = self.io_clock.monotonic() + timeout_s
        while True:
            result = done(bytes(buf))
            if result:
                return bytes(buf), result
            remaining = deadline - self.io_clock.monotonic()
            if remaining <= 0:
                return bytes(buf), None
            buf += self.read_some(remaining)

    def collect(self, quiet_s: float, timeout_s: float) -> bytes:
        """Everything that arrives until ``quiet_s`` of silence (after some data) or timeout."""
        out = bytearray()
        start = last = self.io_clock.monotonic()
        while True:
            now = self.io_clock.monotonic()
            if now - start >= timeout_s or (out and now - last >= quiet_s):
                return bytes(out)
            chunk = self.read_some(min(quiet_s, timeout_s - (now - start)))
            if chunk:
                out += chunk
                last = self.io_clock.monotonic()

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            self.port.close()
        except PORT_ERRORS:
            return  # already gone (unplugged, peer closed): nothing left to release


def driver_on_port(make: Callable[..., D], url: str, *args: Any,
                   port_kw: dict[str, Any] | None = None, **kw: Any) -> D:
    """Every driver's ``from_url``: open ``url`` (:func:`tracker.transport.open_port`, with
    ``port_kw``) and build the driver on it with ``make(port, *args, **kw)``; a driver that
    cannot be built (bad option) closes the port it would have owned."""
    from tracker.transport import open_port

    port = open_port(url, **(port_kw or {}))
    try:
        return make(port, *args, **kw)
    except BaseException:
        port.close()
        raise


class LinkDriver(RotatorDriver):
    """A driver that talks through a :class:`ByteLink`: ``raw`` and ``close`` for all of them.

    ``raw_terminator`` is appended to a raw command that lacks it (b"" for controllers
    without line framing); :meth:`_flush_input` is overridden by drivers that also buffer
    what they have read (a line framer).
    """

    link: ByteLink
    timeout_s: float
    raw_terminator: bytes = b""

    def _flush_input(self) -> None:
        self.link.flush_input()

    def _collect(self, data: bytes, quiet_s: float) -> bytes:
        """Send ``data`` and gather raw bytes until ``quiet_s`` without input or the timeout."""
        with self.link.lock:
            self._flush_input()
            self.link.write(data)
            return self.link.collect(quiet_s, self.timeout_s)

    def raw(self, cmd: str | bytes, quiet_s: float = 0.2) -> bytes:
        """Send one command (the terminator added if missing) and return whatever came back,
        maybe b''."""
        data = cmd.encode("ascii") if isinstance(cmd, str) else bytes(cmd)
        if self.raw_terminator and not data.endswith(self.raw_terminator):
            data += self.raw_terminator
        return self._collect(data, quiet_s)

    def close(self) -> None:
        self.link.close()
