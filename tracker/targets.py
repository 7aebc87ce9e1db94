"""Targets: anything the antenna can point at, resolved from what the user typed.

A target turns UTC times into a :class:`~tracker.skytrack.SkyTrack` as seen from a station.
Satellites come from the element catalogue (:class:`SatelliteTarget`); the Sun, Moon, planets,
fixed radio sources and az/el schedule files come from :mod:`tracker.celestial`, the first of
:data:`RESOLVERS`. :func:`resolve_target` tries the resolvers first, then the catalogue.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np

from tracker import celestial
from tracker.errors import ConfigError, PropagationError
from tracker.skytrack import SkyTrack
from tracker.station import Station
from tracker.sun import satellite_sun_flags


@runtime_checkable
class Target(Protocol):
    name: str
    kind: str  # "satellite", "sun", "moon", "planet", "radio", "schedule"

    def observe(self, station: Station, t_s: np.ndarray) -> SkyTrack:
        """Az/el (and range, range rate, sunlit where meaningful) at UTC POSIX seconds."""


# Resolvers are tried in order before the satellite catalogue; each returns a Target for a
# name it knows, or None.
RESOLVERS: list[Callable[[str], Target | None]] = [celestial.resolve]

# SGP4 mean elements describe an orbit near their epoch: LEO predictions drift by minutes
# within weeks and mean nothing after a year (drag, manoeuvres), and far from the epoch (a
# century) the model returns numbers that look like passes. Beyond this many days on either
# side of the epoch a satellite is refused, before any work; the age warning of the catalogue
# speaks up long before that.
MAX_PROPAGATION_DAYS = 730.0
_UNIX_EPOCH_JD = 2440587.5


class SatelliteTarget:
    """An Earth satellite from an element set (a ``tle.ElementSet`` or skyfield EarthSatellite).

    :meth:`observe` is one vectorised skyfield call for any number of times.
    """

    kind = "satellite"

    def __init__(self, elements: Any):
        from tracker.timescale import timescale

        self.elements = elements
        if hasattr(elements, "earth_satellite"):
            self.satellite = elements.earth_satellite(timescale())
        else:  # already a skyfield EarthSatellite
            self.satellite = elements
        self.name = str(getattr(elements, "name", None) or self.satellite.name or
                        f"NORAD {self.satellite.model.satnum}")

    def __repr__(self) -> str:
        return f"SatelliteTarget({self.name!r})"

    @classmethod
    def from_lines(cls, line1: str, line2: str, name: str = "") -> SatelliteTarget:
        """A target straight from two TLE lines (no catalogue)."""
        from skyfield.sgp4lib import EarthSatellite

        from tracker.timescale import timescale

        return cls(EarthSatellite(line1, line2, name or None, timescale()))

    @property
    def norad_id(self) -> int:
        return int(self.satellite.model.satnum)

    @property
    def period_s(self) -> float:
        """Orbital period from the mean motion (seconds)."""
        return float(2.0 * np.pi / self.satellite.model.no_kozai * 60.0)

    @property
    def is_deep_space(self) -> bool:
        """True for SDP4 (period >= 225 min) orbits."""
        return self.period_s >= 225.0 * 60.0

    @property
    def epoch_s(self) -> float:
        """The elements' epoch in UTC POSIX seconds."""
        model = self.satellite.model
        jd = float(model.jdsatepoch) - _UNIX_EPOCH_JD + float(model.jdsatepochF)
        return jd * 86400.0

    def check_span(self, t0_s: float, t1_s: float) -> None:
        """Raise PropagationError if ``[t0_s, t1_s]`` reaches further than
        :data:`MAX_PROPAGATION_DAYS` from the elements' epoch (in either direction)."""
        from tracker.timescale import utc_strftime

        epoch_s = self.epoch_s
        worst_s = t0_s if abs(t0_s - epoch_s) >= abs(t1_s - epoch_s) else t1_s
        days = (worst_s - epoch_s) / 86400.0
        if abs(days) <= MAX_PROPAGATION_DAYS:
            return
        epoch = utc_strftime(epoch_s, "%Y-%m-%d %H:%M")
        try:
            when = utc_strftime(worst_s, "%Y-%m-%d")
        except (OverflowError, OSError, ValueError):
            when = "the requested time"
        side = "after" if days > 0 else "before"
        raise PropagationError(
            f"{self.name} (NORAD {self.norad_id}): {when} is {abs(days):,.0f} days {side} "
            f"the elements' epoch ({epoch} UTC); SGP4 elements are only usable within "
            f"{MAX_PROPAGATION_DAYS:.0f} days of their epoch: choose a time near the epoch "
            f"or use elements from near that date (`tracker tle update` for current ones)")

    def _check(self, t, values: np.ndarray, position) -> None:
        bad = ~np.isfinite(values)
        if np.any(bad):
            idx = int(np.flatnonzero(np.atleast_1d(bad))[0])
            when = t[idx] if np.ndim(t.tt) else t
            msg = getattr(position, "message", None)
            if isinstance(msg, (list, tuple)):
                msg = msg[idx] if idx < len(msg) else None
            msg = f"SGP4 says {msg!r}" if msg else ""
            raise PropagationError(
                f"{self.name} (NORAD {self.norad_id}): the elements cannot be propagated to "
                f"{when.utc_strftime('%Y-%m-%d %H:%M:%S')} UTC{': ' + msg if msg else ''}; "
                f"the satellite may have decayed or the elements are too old — update them "
                f"with `tracker tle update`")

    def observe(self, station: Station, t_s) -> SkyTrack:
        """Az/el/range/range rate/sunlit at UTC POSIX seconds ``t_s`` (shape ``(n,)``)."""
        from tracker.timescale import time_from_posix

        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        if t_s.size:
            self.check_span(float(t_s.min()), float(t_s.max()))
        t = time_from_posix(t_s)
        topos = station.topos()
        geocentric = self.satellite.at(t)
        topocentric = geocentric - topos.at(t)
        el, az, dist, _, _, range_rate = topocentric.frame_latlon_and_rates(topos)
        el_deg = np.atleast_1d(el.degrees)
        self._check(t, el_deg, geocentric)
        sunlit, _ = satellite_sun_flags(self.satellite.model, t_s, station.lat_deg,
                                        station.lon_deg)
        return SkyTrack(t_s, np.mod(np.atleast_1d(az.degrees), 360.0), el_deg,
                        np.atleast_1d(dist.km), np.atleast_1d(range_rate.km_per_s), sunlit,
                        self.name, {"norad_id": self.norad_id})

    def elevation(self, station: Station, t_s) -> tuple[np.ndarray, np.ndarray]:
        """(az_deg, el_deg) only — cheaper than :meth:`observe` for event searches."""
        from tracker.timescale import time_from_posix

        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        if t_s.size:
            self.check_span(float(t_s.min()), float(t_s.max()))
        t = time_from_posix(t_s)
        topos = station.topos()
        position = (self.satellite - topos).at(t)
        alt, az, _ = position.altaz()
        el_deg = np.atleast_1d(alt.degrees)
        self._check(t, el_deg, position)
        return np.mod(np.atleast_1d(az.degrees), 360.0), el_deg


def _catalog_find(catalog: Any, query: str):
    return catalog.find(query)


def resolve_target(query: str, catalog: Any = None) -> Target:
    """The target called ``query``: a registered resolver's, else a catalogue satellite.

    ``catalog`` is a ``tle.catalog.Catalog`` or a zero-argument callable returning one (so
    the catalogue is only loaded when a resolver does not know the name). Unknown or
    ambiguous names raise the catalogue's error, which carries suggestions.
    """
    text = query.strip()
    if not text:
        raise ConfigError("empty target name; give a satellite name, NORAD id or e.g. 'Sun'")
    for resolver in RESOLVERS:
        target = resolver(text)
        if target is not None:
            return target
    if catalog is None:
        from tle.catalog import Catalog

        catalog = Catalog.default()
    elif callable(catalog) and not hasattr(catalog, "find"):
        catalog = catalog()
    return SatelliteTarget(_catalog_find(catalog, text))


def warn(message: str) -> None:
    """One note on stderr (for commands)."""
    print(f"tracker: note: {message}", file=sys.stderr)
