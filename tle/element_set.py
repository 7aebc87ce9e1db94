"""``ElementSet``, one satellite's mean elements, and the warning-callback type.

Its own module because both parsers build it: :mod:`tle.elements` (TLE/3LE, and the loader
that picks a parser) and :mod:`tle.omm` (OMM JSON/CSV/XML).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from tle.errors import TleError

WarningHandler = Callable[[str], None]


@dataclass(frozen=True)
class ElementSet:
    """One satellite's mean elements, from a TLE (``line1``/``line2``) or an OMM record (``omm``).

    ``source`` is the file or URL it came from and ``line_no`` the line (TLE line 1, CSV row) or
    record number (JSON, XML) there, so any later problem can point back at it.
    """

    name: str
    norad_id: int
    intl_designator: str
    epoch: datetime
    line1: str | None
    line2: str | None
    source: str = "<string>"
    line_no: int = 0
    omm: Mapping[str, Any] | None = field(default=None, compare=False, hash=False, repr=False)

    @property
    def group(self) -> str:
        """The source's file stem ("amateur" for .../amateur.txt): the catalogue group."""
        return Path(self.source).stem if self.source and not self.source.startswith("<") else ""

    @property
    def mean_motion_rev_day(self) -> float:
        """Revolutions per day (SGP4 for > 6.4, SDP4 deep space below)."""
        if self.line2 is not None:
            return float(self.line2[52:63])
        return float(self.omm["MEAN_MOTION"])  # type: ignore[index]

    def satrec(self):
        """A fresh ``sgp4.api.Satrec`` (from the lines, or ``sgp4.omm.initialize`` for OMM)."""
        from sgp4.api import Satrec

        if self.line1 is not None and self.line2 is not None:
            return Satrec.twoline2rv(self.line1, self.line2)
        from sgp4 import omm

        sat = Satrec()
        omm.initialize(sat, self.omm)
        return sat

    def earth_satellite(self, ts):
        """A skyfield ``EarthSatellite`` on timescale ``ts``, keeping this set's name."""
        from skyfield.sgp4lib import EarthSatellite

        if self.line1 is not None and self.line2 is not None:
            return EarthSatellite(self.line1, self.line2, self.name, ts)
        sat = EarthSatellite.from_satrec(self.satrec(), ts)
        sat.name = self.name
        return sat

    def age_days(self, now: datetime) -> float:
        """Days from the epoch to ``now`` (an aware datetime); negative for future epochs."""
        if now.tzinfo is None:
            raise TleError("age_days needs an aware datetime (UTC), got a naive one")
        return (now - self.epoch).total_seconds() / 86400.0
