"""An emulated controller by protocol name, as the registry (:mod:`tracker.controllers`)
names it: ``tracker emulate --protocol``, ``emu://`` URLs, the demos and the tests' rigs all
make their emulators here."""

from __future__ import annotations

from typing import Any

from tracker.clock import Clock
from tracker.controllers import find, names, with_emulator
from tracker.errors import ConfigError
from tracker.mount import RotatorSpec, preset


def make_emulator(protocol: str, clock: Clock, spec: RotatorSpec | None = None,
                  **kw: Any) -> Any:
    """The emulator of ``protocol`` on ``clock``, driving ``spec`` (default: the protocol's
    default rotator). ``kw`` go to the controller (``az_deg``; ``el_deg`` for a controller
    with elevation; ``options`` ...). Raises :class:`ConfigError` (a ``ValueError``) for a
    protocol without an emulator, listing the ones that have one."""
    entry = find(protocol)
    if entry is None or entry.emulator is None or entry.default_rotator is None:
        raise ConfigError(f"no emulator for {protocol!r}; known: "
                          f"{', '.join(names(with_emulator()))}")
    return entry.emulator_factory()(str(protocol).lower(), clock,
                                    spec or preset(entry.default_rotator), **kw)
