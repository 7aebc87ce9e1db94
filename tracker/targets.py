"""Targets: anything the antenna can point at, resolved from what the user typed.

A target turns UTC times into a :class:`~tracker.skytrack.SkyTrack` as seen from a station.
Satellites come from the element catalogue; the Sun, Moon, planets, fixed radio sources and
az/el schedule files are added by :mod:`tracker.celestial` through :data:`RESOLVERS`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

import numpy as np

from tracker.skytrack import SkyTrack
from tracker.station import Station


@runtime_checkable
class Target(Protocol):
    name: str
    kind: str  # "satellite", "sun", "moon", "planet", "radio", "schedule"

    def observe(self, station: Station, t_s: np.ndarray) -> SkyTrack:
        """Az/el (and range, range rate, sunlit where meaningful) at UTC POSIX seconds."""


# Resolvers are tried in order before the satellite catalogue; each returns a Target for a
# name it knows, or None. tracker.celestial registers itself here.
RESOLVERS: list[Callable[[str], Target | None]] = []
