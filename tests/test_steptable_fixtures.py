"""Shared fixtures for the step-table and upload tests: real ISS passes from a fixed TLE.

No tests here. Tracks are computed with skyfield directly from ``tests/data/steptable_iss.tle``
(ISS elements, epoch 2026-08-22) over a fixed window, so every run sees the same passes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from _paths import DATA

from tracker.skytrack import SkyTrack
from tracker.station import Station

STATION = Station("JO22", lat_deg=52.0, lon_deg=4.5, alt_m=10.0)


@lru_cache(maxsize=8)
def iss_passes(min_max_el_deg: float = 0.0) -> tuple[tuple[float, float, float], ...]:
    """(aos_s, los_s, max_el_deg) of the ISS passes over STATION, 2026-08-23..25 UTC."""
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale(builtin=True)
    lines = (DATA / "steptable_iss.tle").read_text().splitlines()
    sat = EarthSatellite(lines[1], lines[2], lines[0].strip(), ts)
    topos = wgs84.latlon(STATION.lat_deg, STATION.lon_deg, elevation_m=STATION.alt_m)
    t, events = sat.find_events(topos, ts.utc(2026, 8, 23), ts.utc(2026, 8, 25),
                                altitude_degrees=0.0)
    out = []
    for i in range(len(events) - 2):
        if tuple(events[i:i + 3]) == (0, 1, 2):
            alt = (sat - topos).at(t[i + 1]).altaz()[0].degrees
            if alt >= min_max_el_deg:
                out.append((t[i].utc_datetime().timestamp(),
                            t[i + 2].utc_datetime().timestamp(), float(alt)))
    return tuple(out)


@lru_cache(maxsize=16)
def iss_track(aos_s: float, los_s: float, step_s: float = 1.0) -> SkyTrack:
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale(builtin=True)
    lines = (DATA / "steptable_iss.tle").read_text().splitlines()
    sat = EarthSatellite(lines[1], lines[2], lines[0].strip(), ts)
    topos = wgs84.latlon(STATION.lat_deg, STATION.lon_deg, elevation_m=STATION.alt_m)
    t_s = np.arange(aos_s, los_s, step_s)
    t = ts.from_datetimes([__import__("datetime").datetime.fromtimestamp(
        x, __import__("datetime").timezone.utc) for x in t_s])
    alt, az, _ = (sat - topos).at(t).altaz()
    return SkyTrack.from_azel(t_s, az.degrees, np.maximum(alt.degrees, 0.0), name="ISS (ZARYA)")


def high_pass() -> SkyTrack:
    """The highest pass in the window (fast azimuth near TCA)."""
    aos, los, _ = max(iss_passes(), key=lambda p: p[2])
    return iss_track(aos, los)


def low_pass() -> SkyTrack:
    aos, los, _ = min(iss_passes(10.0), key=lambda p: p[2])
    return iss_track(aos, los)
