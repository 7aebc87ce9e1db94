"""The emulators of the non-GS-232 protocols, by protocol name (``tracker emulate --protocol``,
``emu://`` URLs, the demo).

A module of its own so each controller module only knows its own controller: the factory
names all of them, the controllers name none of the others.
"""

from __future__ import annotations

from typing import Literal

from tracker.clock import Clock
from tracker.emulator.azaz_controller import AzAzController
from tracker.emulator.rotorez_controller import RotorEzController
from tracker.emulator.sak232_controller import Sak232Controller
from tracker.mount import RotatorSpec

OTHER_PROTOCOLS = ("rotorez", "dcu1", "sak232", "gs232b-azaz")


def make_other_controller(protocol: str, clock: Clock, spec: RotatorSpec | None = None,
                          az_deg: float | None = None):
    """The emulator for a non-GS-232 ``protocol`` (one of :data:`OTHER_PROTOCOLS`) with its
    own default rotator unless ``spec`` is given (used azimuth-only)."""
    name = protocol.lower()
    if name in ("rotorez", "dcu1"):
        variant: Literal["rotorez", "dcu1"] = "dcu1" if name == "dcu1" else "rotorez"
        return RotorEzController(variant, spec, clock, az_deg=az_deg)
    if name == "sak232":
        return Sak232Controller(spec, clock, az_deg=az_deg)
    if name == "gs232b-azaz":
        return AzAzController(spec, None, clock, az_deg=az_deg)
    raise ValueError(f"{protocol!r} is not one of {', '.join(OTHER_PROTOCOLS)}")
