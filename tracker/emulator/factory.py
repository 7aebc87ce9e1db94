"""An emulated controller by protocol name, as the registry (:mod:`tracker.controllers`)
names it: ``tracker emulate --protocol``, ``emu://`` URLs, the demos and the tests' rigs all
make their emulators here."""

from __future__ import annotations

from typing import Any

from tracker.clock import Clock
from tracker.controllers import find, names, with_emulator
from tracker.errors import ConfigError
from tracker.mount import RotatorSpec, preset


def check_start_position(spec: RotatorSpec, az_deg: float | None, el_deg: float | None, *,
                         az_name: str = "az", el_name: str = "el") -> None:
    """Refuse (ConfigError) a starting position outside the rotator's travel: a simulated
    antenna beyond its end stops would read back positions no real unit can report."""
    (az_min, az_max), el_lim = spec.axis_limits()
    if az_deg is not None and not az_min <= az_deg <= az_max:   # NaN fails too
        raise ConfigError(f"{az_name} {az_deg:g} is outside the {spec.name} travel "
                          f"{az_min:g}..{az_max:g} deg (mechanical)")
    if el_deg is not None:
        if el_lim is None:
            raise ConfigError(f"{el_name} given but the {spec.name} has no elevation axis")
        if not el_lim[0] <= el_deg <= el_lim[1]:
            raise ConfigError(f"{el_name} {el_deg:g} is outside the {spec.name} travel "
                              f"{el_lim[0]:g}..{el_lim[1]:g} deg")


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
    spec = spec or preset(entry.default_rotator)
    check_start_position(spec, kw.get("az_deg"), kw.get("el_deg"))
    return entry.emulator_factory()(str(protocol).lower(), clock, spec, **kw)
