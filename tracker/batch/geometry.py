"""Vectorised geometry for the batch finder: Earth rotation, station frames, look angles, Sun.

Frames follow skyfield's satellite pipeline so results agree with ``find_events``: SGP4 gives
TEME positions; TEME -> ITRS is a rotation about z by GMST (IAU 1982, on UT1), polar motion is
neglected (skyfield's default too); stations are WGS84 geodetic points and elevation is taken
against the geodetic normal, with no refraction.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from tracker.station import Station
from tracker.sun import in_sunlight, sun_distance_km, sun_sin_elevation, sun_teme_unit

WGS84_A_KM = 6378.137
WGS84_F = 1.0 / 298.257223563
EARTH_ROTATION_RAD_S = 7.292115e-5  # skyfield.sgp4lib.ANGVEL (the Earth's sidereal rate)
MU_KM3_S2 = 398600.4418
DAY_S = 86400.0


def gmst_rad(jd_ut1_whole, fraction_ut1) -> np.ndarray:
    """GMST 1982 angle in radians (the TEME -> ITRS angle), vectorised over times."""
    from skyfield.sgp4lib import theta_GMST1982

    theta, _ = theta_GMST1982(jd_ut1_whole, fraction_ut1)
    return np.asarray(theta, dtype=float)


@dataclass(frozen=True)
class StationFrames:
    """Stations as arrays: ECEF position, local east/north/up unit vectors, screening radii."""

    ecef_km: np.ndarray  # (N, 3)
    east: np.ndarray  # (N, 3)
    north: np.ndarray  # (N, 3)
    up: np.ndarray  # (N, 3)
    radius_km: np.ndarray  # (N,) geocentric distance of the station
    unit: np.ndarray  # (N, 3) geocentric unit vector (ECEF)
    cos_lat: np.ndarray  # (N,) geocentric latitude cosine (how fast the station moves in TEME)
    min_el_deg: np.ndarray  # (N,) lowest threshold anywhere (the mask only raises it)

    @classmethod
    def from_stations(cls, stations: list[Station], min_el_deg: float | None = None
                      ) -> StationFrames:
        lat = np.radians([s.lat_deg for s in stations])
        lon = np.radians([s.lon_deg for s in stations])
        alt_km = np.array([s.alt_m for s in stations]) / 1000.0
        e2 = WGS84_F * (2.0 - WGS84_F)
        n = WGS84_A_KM / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
        ecef = np.stack([(n + alt_km) * np.cos(lat) * np.cos(lon),
                         (n + alt_km) * np.cos(lat) * np.sin(lon),
                         (n * (1.0 - e2) + alt_km) * np.sin(lat)], axis=-1)
        up = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], -1)
        east = np.stack([-np.sin(lon), np.cos(lon), np.zeros_like(lon)], -1)
        north = np.cross(up, east)
        radius = np.linalg.norm(ecef, axis=-1)
        unit = ecef / radius[:, None]
        thr = np.array([s.min_el_deg if min_el_deg is None else min_el_deg for s in stations],
                       dtype=float)
        return cls(ecef, east, north, up, radius, unit, np.hypot(unit[:, 0], unit[:, 1]), thr)

    def __len__(self) -> int:
        return len(self.radius_km)


def station_columns(table: np.ndarray, station_idx) -> np.ndarray:
    """Components (3, ...) of per-station vectors ``table`` (N, 3) at ``station_idx`` (an
    int or an array of indices): one contiguous gather per component."""
    return np.take(np.ascontiguousarray(table.T), station_idx, axis=1)


def teme_to_ecef(r_teme, v_teme, theta_rad):
    """Rotate TEME position/velocity (..., 3) into ECEF at GMST angle(s) ``theta_rad`` (...).

    Returns two tuples of components ``(x, y, z), (vx, vy, vz)`` (arrays, no stacking).
    """
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    rx, ry = r_teme[..., 0], r_teme[..., 1]
    x = c * rx + s * ry
    y = c * ry - s * rx
    # The frame turns with the Earth: v_ecef = R v_teme - omega x r_ecef.
    vx = c * v_teme[..., 0] + s * v_teme[..., 1] + EARTH_ROTATION_RAD_S * y
    vy = c * v_teme[..., 1] - s * v_teme[..., 0] - EARTH_ROTATION_RAD_S * x
    return (x, y, r_teme[..., 2]), (vx, vy, v_teme[..., 2])


def look_angles(r_ecef, v_ecef, frames: StationFrames, station_idx, with_az: bool = True):
    """Elevation, azimuth (deg) and elevation rate (deg/s) of satellites seen from stations.

    ``r_ecef``/``v_ecef`` are component tuples as returned by :func:`teme_to_ecef`;
    ``station_idx`` (an int or an array like the components) picks each sample's station.
    ``with_az`` False leaves the azimuth out (None).
    """
    o, u = station_columns(frames.ecef_km, station_idx), station_columns(frames.up, station_idx)
    dx, dy, dz = r_ecef[0] - o[0], r_ecef[1] - o[1], r_ecef[2] - o[2]
    ru = dx * u[0] + dy * u[1] + dz * u[2]
    dist2 = dx * dx + dy * dy + dz * dz
    inv = 1.0 / np.sqrt(dist2)
    sin_el = np.clip(ru * inv, -1.0, 1.0)
    el = np.degrees(np.arcsin(sin_el))
    az = None
    if with_az:
        e = station_columns(frames.east, station_idx)
        n = station_columns(frames.north, station_idx)
        re = dx * e[0] + dy * e[1]
        rn = dx * n[0] + dy * n[1] + dz * n[2]
        az = np.degrees(np.arctan2(re, rn)) % 360.0
    vx, vy, vz = v_ecef
    vu = vx * u[0] + vy * u[1] + vz * u[2]
    rv = dx * vx + dy * vy + dz * vz
    d_sin = (vu - ru * rv / dist2) * inv
    rate = np.degrees(d_sin / np.sqrt(np.maximum(1.0 - sin_el * sin_el, 1e-12)))
    return el, az, rate


def horizon_angle_rad(r_km, station_radius_km, el_deg) -> np.ndarray:
    """Largest geocentric angle between station and a satellite at distance ``r_km`` for which
    the satellite is at elevation >= ``el_deg`` (spherical Earth through the station)."""
    el = np.radians(el_deg)
    ratio = np.clip(station_radius_km * np.cos(el) / np.maximum(r_km, station_radius_km), -1, 1)
    return np.arccos(ratio) - el


def sun_flags(r_teme_km, tau_s, jd0: float, fr0: float, theta_rad, frames: StationFrames,
              station, grid_s: float = 3600.0):
    """(sunlit, sine of the Sun's elevation at ``station``) at times ``tau_s`` (seconds after
    the Julian date ``jd0 + fr0``) for satellites at TEME positions ``r_teme_km`` (n, 3),
    seen from ``station`` (an index, or one per position).

    The Sun's direction and distance (:mod:`tracker.sun`) are computed on a ``grid_s`` grid
    and interpolated linearly (the Sun moves 0.04 deg an hour: the chord error is ~1e-7
    rad). Sunlit means the Sun-ward ray misses a spherical Earth.
    """
    tau_s = np.asarray(tau_s, dtype=float)
    if tau_s.size == 0:
        return np.zeros(0, bool), np.zeros(0)
    t0, t_grid, table = sun_table(tau_s, jd0, fr0, grid_s)
    i = np.clip(np.floor(tau_s / grid_s).astype(np.int64) - t0, 0, len(table) - 1)
    row = table[i]
    dt = tau_s - t_grid[i]
    sx, sy, sz, dist = (row[:, k] + row[:, k + 4] * dt for k in range(4))
    lit = in_sunlight((r_teme_km[:, 0], r_teme_km[:, 1], r_teme_km[:, 2]),
                      (sx * dist, sy * dist, sz * dist))
    return lit, sun_sin_elevation((sx, sy, sz), theta_rad, station_columns(frames.up, station))


def sun_table(tau_s, jd0: float, fr0: float, grid_s: float):
    """The Sun on :func:`sun_flags`' grid over the times ``tau_s`` (not empty): (index of
    the first grid time, grid times (s), per grid interval its start value and slope of the
    Sun's TEME unit vector and distance (km), (m, 8))."""
    t0, t1 = math.floor(tau_s.min() / grid_s), math.ceil(tau_s.max() / grid_s) + 1
    t_grid = np.arange(t0, t1 + 1) * grid_s
    jd_grid = jd0 + (fr0 + t_grid / DAY_S)
    node = np.column_stack([sun_teme_unit(jd_grid), sun_distance_km(jd_grid)])
    # Linear interpolation: per grid interval its start value and slope, one gather.
    return t0, t_grid, np.concatenate([node[:-1], np.diff(node, axis=0) / grid_s], axis=1)


def orbit_bounds(satrecs) -> tuple[np.ndarray, np.ndarray]:
    """(apogee radius km, fastest orbital angular rate rad/s) per Satrec, from the mean
    elements."""
    n_rad_s = np.maximum(np.array([sr.no_kozai for sr in satrecs], dtype=float), 1e-6) / 60.0
    e = np.clip(np.array([sr.ecco for sr in satrecs], dtype=float), 0.0, 0.999)
    a_km = (MU_KM3_S2 / n_rad_s**2) ** (1.0 / 3.0)
    rate = n_rad_s * (1.0 + e) ** 2 / (1.0 - e * e) ** 1.5
    return a_km * (1.0 + e), rate


@functools.lru_cache(maxsize=64)
def dut1_s(start_utc) -> float:
    """UT1 - UTC at ``start_utc`` from skyfield's bundled IERS table (changes ~ms per week).
    Cached: building the time scale costs more than a small batch job."""
    from tracker.timescale import timescale

    value = float(timescale().from_datetime(start_utc).dut1)
    return value if math.isfinite(value) else 0.0
