"""The controller registry: one entry per controller, owning every fact the code asks about it.

Each :class:`Controller` names the ``--protocol`` values it answers to, its driver, its
emulator, the rotator its demo drives, and the capabilities callers decide on (position
query, elevation axis, step tables, baud rate, two antennas on one port). Commands, the
``emu://`` handler, ``tracker emulate`` and the tests look a controller up here and nowhere
else; adding a controller family is one entry in :data:`CONTROLLERS`.

The registry sits below every layer it names: drivers and emulators are given as import
paths (``"package.module:callable"``) and imported only when :meth:`Controller.driver_factory`
or :meth:`Controller.emulator_factory` is called, so the wire layer (``tracker.protocols``)
can consult it without importing the emulator, and the static import graph keeps its layers.

Factory contracts:

- driver: ``factory(protocol, url, **kw) -> RotatorDriver``; ``kw`` as for
  :func:`tracker.protocols.open_driver` (``baudrate``, ``timeout_s``, ``clock``, limits ...).
- emulator: ``factory(protocol, clock, spec, **kw) -> controller``; ``spec`` is a
  :class:`tracker.mount.RotatorSpec`, ``kw`` go to the controller's constructor: ``az_deg``
  always, ``el_deg`` when :attr:`Controller.has_elevation`, ``options``
  (:class:`tracker.emulator.EmulatorOptions`) when :attr:`Controller.gs232_switches`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from tracker.errors import ConfigError


@dataclass(frozen=True)
class Controller:
    """One controller (or dialect): everything the rest of the code consults about it.

    ``names``: what ``--protocol`` accepts, the first being the canonical one; names share
    an entry only when every fact below holds for all of them (the factories get the name,
    so one family's dialects can still differ on the wire). ``family``: the codec the
    entry's dialect belongs to (several entries may share one). ``default_rotator``: the
    preset (:func:`tracker.mount.preset`) a demo or an emulator drives when no rotator is
    named. ``step_tables``: the :mod:`tracker.steptable` profile of its on-box timed
    tables, None without tables. ``baudrate``: None for a network protocol.
    ``dual_azimuth``: two azimuth-only antennas on one port (``--target2``, ``sync``).
    ``gs232_switches``: the emulator takes the GS-232 switches (autobaud, strict acks, C2
    spacing, 0-359 read-back, table end). ``port_hint``: what ``--port`` must name when
    there is no emulator to run a demo on.
    """

    names: tuple[str, ...]
    family: str
    description: str
    driver: str | Callable[..., Any]
    emulator: str | Callable[..., Any] | None = None
    default_rotator: str | None = "G-5500"
    has_position_query: bool = True
    has_elevation: bool = True
    step_tables: str | None = None
    baudrate: int | None = 9600
    dual_azimuth: bool = False
    gs232_switches: bool = False
    port_hint: str = ""

    @property
    def name(self) -> str:
        return self.names[0]

    @property
    def open_loop(self) -> bool:
        """No position query: the driver tracks on the motor model's estimate."""
        return not self.has_position_query

    def driver_factory(self) -> Callable[..., Any]:
        return _resolve(self.driver)

    def emulator_factory(self) -> Callable[..., Any]:
        if self.emulator is None:
            raise ConfigError(f"protocol {self.name} has no emulator"
                              + (f"; connect to {self.port_hint}" if self.port_hint else ""))
        return _resolve(self.emulator)


def _resolve(target: str | Callable[..., Any]) -> Callable[..., Any]:
    if callable(target):
        return target
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def _gs232(name: str, description: str, step_tables: str | None) -> Controller:
    return Controller(
        (name,), "gs232", description, "tracker.protocols.gs232:open_gs232",
        "tracker.emulator.gs232_controller:emulate", step_tables=step_tables,
        gs232_switches=True)


CONTROLLERS: list[Controller] = [
    _gs232("gs232a", "Yaesu GS-232A: +0aaa+0eee, CR acknowledgements", "gs232a"),
    _gs232("gs23", "Kenpro GS-23/GS-232: as the GS-232A, the original help screens", None),
    _gs232("gs232b", "Yaesu GS-232B as real units behave: AZ=aaa  EL=eee, silent sets",
           "gs232b"),
    _gs232("gs232b-manual", "Yaesu GS-232B as the manual reads: one space, CR after every "
                            "command", "gs232b"),
    _gs232("k3ng", "K3NG Arduino controller in GS-232B emulation, 20-point timed buffer",
           "k3ng"),
    Controller(("rotorez",), "rotorez", "Idiom Press Rotor-EZ / RotorCard, azimuth only",
               "tracker.protocols.rotorez:open_rotorez",
               "tracker.emulator.rotorez_controller:emulate", default_rotator="HAM-IV",
               has_elevation=False, baudrate=4800),
    Controller(("dcu1",), "rotorez", "Hy-Gain DCU-1: set only, tracked open loop",
               "tracker.protocols.rotorez:open_rotorez",
               "tracker.emulator.rotorez_controller:emulate", default_rotator="HAM-IV",
               has_position_query=False, has_elevation=False, baudrate=4800),
    Controller(("sak232",), "sak232", "Zelpro SAK-232: no replies, tracked open loop",
               "tracker.protocols.sak232:open_sak232",
               "tracker.emulator.sak232_controller:emulate", default_rotator="Zelpro-RAU",
               has_position_query=False, has_elevation=False),
    # The AZ/AZ box's tables are the GS-232B's (M per antenna), so it shares that profile.
    Controller(("gs232b-azaz", "gs232b-azaz2"), "azaz",
               "GS-232B-AZ/AZ: two azimuth rotators on one port (antenna 1, antenna 2)",
               "tracker.protocols.azaz:open_azaz", "tracker.emulator.azaz_controller:emulate",
               default_rotator="AZ-360", has_elevation=False, step_tables="gs232b",
               dual_azimuth=True),
    Controller(("easycomm2", "easycomm3"), "easycomm",
               "Easycomm II / III (Hamlib 202 / 204, SatNOGS): AZaaa.a ELeee.e lines",
               "tracker.protocols.easycomm:open_easycomm",
               "tracker.emulator.easycomm_controller:emulate"),
    Controller(("rotctld",), "rotctld", "Hamlib rotctld over TCP: any rotator Hamlib drives",
               "tracker.protocols.rotctld:open_rotctld", default_rotator=None, baudrate=None,
               port_hint="HOST:PORT of a running rotctld (e.g. rotctld -m 1 for Hamlib's "
                         "dummy rotator)"),
]


def register_controller(entry: Controller) -> None:
    """Add ``entry`` (a controller from outside this package); its names must be new."""
    taken = [n for n in entry.names if find(n) is not None]
    if taken:
        raise ConfigError(f"protocol {taken[0]!r} is already registered")
    CONTROLLERS.append(entry)


def find(protocol: str) -> Controller | None:
    """The entry ``protocol`` names (any letter case), or None."""
    key = str(protocol).lower()
    for entry in CONTROLLERS:
        if key in entry.names:
            return entry
    return None


def controller(protocol: str) -> Controller:
    """The entry ``protocol`` names; an unknown name raises :class:`ConfigError` listing
    the known ones."""
    entry = find(protocol)
    if entry is None:
        raise ConfigError(f"unknown protocol {protocol!r}; known: {', '.join(names())}")
    return entry


def names(entries: Iterable[Controller] | None = None) -> list[str]:
    """Every protocol name (of ``entries``, default all), sorted."""
    return sorted(n for e in (CONTROLLERS if entries is None else entries) for n in e.names)


def with_emulator() -> list[Controller]:
    return [e for e in CONTROLLERS if e.emulator is not None]


def in_family(family: str) -> list[str]:
    """The protocol names of one codec family, in registry order."""
    return [n for e in CONTROLLERS if e.family == family for n in e.names]
