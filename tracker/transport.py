"""The one place the project opens ports.

Every driver takes an already-open, port-like object; this function makes one from any
pyserial URL: ``/dev/ttyUSB0``, ``COM3``, ``socket://127.0.0.1:4533``, ``rfc2217://...``,
``spy://...``. pyserial errors are translated here, at the boundary.
"""

from __future__ import annotations

import serial

from tracker.errors import RotatorIOError


def open_port(url: str, baudrate: int = 9600, timeout_s: float = 1.0,
              write_timeout_s: float | None = 2.0, rtscts: bool = False, **kwargs):
    """Open ``url`` with :func:`serial.serial_for_url`; raises :class:`RotatorIOError`."""
    try:
        return serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s,
                                     write_timeout=write_timeout_s, rtscts=rtscts, **kwargs)
    except (serial.SerialException, OSError, ValueError) as e:
        raise RotatorIOError(f"cannot open port {url!r}: {e}. Check the device path or URL "
                             f"(e.g. /dev/ttyUSB0, COM3, socket://127.0.0.1:4533)") from e
