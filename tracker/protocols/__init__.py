"""Rotator protocol drivers.

Which driver a protocol name gets, and every other fact about a controller, is in the
registry (:mod:`tracker.controllers`); :func:`open_driver` opens any pyserial URL with the
driver the registry names.
"""

from __future__ import annotations

from typing import Any

from tracker.controllers import controller
from tracker.protocols.base import Capabilities, RotatorDriver


def open_driver(url: str, protocol: str = "gs232b", **kw: Any) -> RotatorDriver:
    """Open ``url`` (``/dev/ttyUSB0``, ``socket://host:port``, ...) with ``protocol``'s driver.
    Keyword arguments go to the driver (``baudrate``, ``timeout_s``, ``has_elevation``, ...);
    without ``baudrate`` the controller's default applies. An unknown protocol raises
    :class:`tracker.errors.ConfigError` listing the known ones."""
    entry = controller(protocol)
    if kw.get("baudrate") is None:
        kw.pop("baudrate", None)
        if entry.baudrate is not None:
            kw["baudrate"] = entry.baudrate
    driver: RotatorDriver = entry.driver_factory()(protocol.lower(), url, **kw)
    return driver


__all__ = ["Capabilities", "RotatorDriver", "open_driver"]
