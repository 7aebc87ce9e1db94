"""Rotator protocol drivers and their registry.

``DRIVERS`` maps a protocol name (what ``--protocol`` accepts) to a factory
``(url, **kw) -> RotatorDriver``. A new protocol module registers itself with
:func:`register_driver`; :func:`open_driver` opens any pyserial URL with the right one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tracker.errors import ConfigError
from tracker.protocols.base import Capabilities, RotatorDriver

DriverFactory = Callable[..., RotatorDriver]
DRIVERS: dict[str, DriverFactory] = {}


def register_driver(name: str, factory: DriverFactory) -> None:
    DRIVERS[name.lower()] = factory


def _gs232_factory(profile: str) -> DriverFactory:
    def open_gs232(url: str, **kw: Any) -> RotatorDriver:
        from tracker.protocols.gs232 import Gs232Driver

        return Gs232Driver.from_url(url, profile, **kw)
    return open_gs232


for _name in ("gs232a", "gs23", "gs232b", "gs232b-manual", "k3ng"):
    register_driver(_name, _gs232_factory(_name))


def _lazy_factory(module: str, attr: str) -> DriverFactory:
    def open_lazily(url: str, **kw: Any) -> RotatorDriver:
        import importlib

        return getattr(importlib.import_module(f"tracker.protocols.{module}"), attr)(url, **kw)
    return open_lazily


# The other controller families and Hamlib's rotctld, imported on first use.
for _name, _module, _attr in (("rotorez", "rotorez", "open_rotorez"),
                              ("dcu1", "rotorez", "open_dcu1"),
                              ("sak232", "sak232", "open_sak232"),
                              ("gs232b-azaz", "azaz", "open_azaz"),
                              ("gs232b-azaz2", "azaz", "open_azaz2"),
                              ("rotctld", "rotctld", "open_rotctld")):
    register_driver(_name, _lazy_factory(_module, _attr))


def open_driver(url: str, protocol: str = "gs232b", **kw: Any) -> RotatorDriver:
    """Open ``url`` (``/dev/ttyUSB0``, ``socket://host:port``, ...) with ``protocol``'s driver.
    Keyword arguments go to the driver (``baudrate``, ``timeout_s``, ``has_elevation``, ...)."""
    factory = DRIVERS.get(protocol.lower())
    if factory is None:
        raise ConfigError(f"unknown protocol {protocol!r}; known: {', '.join(sorted(DRIVERS))}")
    return factory(url, **kw)


__all__ = ["DRIVERS", "Capabilities", "RotatorDriver", "open_driver", "register_driver"]
