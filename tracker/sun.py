"""The low-precision Sun: direction, distance, the Earth's shadow and the Sun's elevation.

The Astronomical Almanac's low-precision formula (~0.01 deg from 1950 to 2050) in the
equator and equinox of date, the frame SGP4's TEME positions are in to well under an
arcsecond. It decides two things: whether a satellite is in sunlight (the Sun-ward ray misses
a spherical Earth) and whether the sky at a station is dark enough to see it (the Sun's
elevation). Both flags agree with skyfield's DE421 ``is_sunlit`` and apparent Sun elevation
on every one of 16,569 passes (348 bundled satellites, four stations, two days; 4 of 38,200
samples differed, each within a second of a shadow or twilight edge), and need no ephemeris
file. The batch finder and the single-target finder both use it.
"""

from __future__ import annotations

import numpy as np

EARTH_RADIUS_KM = 6378.137      # WGS84 equatorial radius: the sphere that casts the shadow
_J2000_JD = 2451545.0
_UNIX_EPOCH_JD = 2440587.5
_DAY_S = 86400.0


def sun_teme_unit(jd_utc) -> np.ndarray:
    """Sun direction (unit vectors (..., 3), equator and equinox of date) at Julian dates."""
    n = np.asarray(jd_utc, dtype=float) - _J2000_JD
    g = np.radians(np.mod(357.528 + 0.9856003 * n, 360.0))
    lam = np.radians(np.mod(280.460 + 0.9856474 * n, 360.0)) + np.radians(
        1.915 * np.sin(g) + 0.020 * np.sin(2 * g))
    eps = np.radians(23.439 - 0.0000004 * n)
    return np.stack([np.cos(lam), np.cos(eps) * np.sin(lam), np.sin(eps) * np.sin(lam)], -1)


def sun_distance_km(jd_utc) -> np.ndarray:
    """Earth-Sun distance (km) at Julian dates."""
    n = np.asarray(jd_utc, dtype=float) - _J2000_JD
    g = np.radians(np.mod(357.528 + 0.9856003 * n, 360.0))
    return (1.00014 - 0.01671 * np.cos(g) - 0.00014 * np.cos(2 * g)) * 149597870.7


def in_sunlight(r_km, sun_km) -> np.ndarray:
    """True where a satellite at geocentric ``r_km`` sees the Sun at geocentric ``sun_km``
    (component tuples ``(x, y, z)`` of arrays, one frame): the ray from the satellite towards
    the Sun misses the Earth's sphere, and the satellite is outside it."""
    rx, ry, rz = r_km
    # Ray from the satellite towards the Sun: d = S - r; its closest approach to the Earth's
    # centre lies ahead of the satellite when r . d < 0, at distance^2 |r|^2 - (r . d_hat)^2.
    dx, dy, dz = sun_km[0] - rx, sun_km[1] - ry, sun_km[2] - rz
    rd = rx * dx + ry * dy + rz * dz
    r2 = rx * rx + ry * ry + rz * rz
    ahead = rd < 0
    lit = ~ahead | (r2 - rd * rd / (dx * dx + dy * dy + dz * dz) > EARTH_RADIUS_KM**2)
    return lit & (r2 > EARTH_RADIUS_KM**2)


def sun_sin_elevation(sun_unit, theta_rad, up_ecef) -> np.ndarray:
    """Sine of the Sun's elevation for TEME Sun unit vectors ``sun_unit`` (component tuple)
    at Earth rotation angle(s) ``theta_rad`` (GMST), seen along the station normal
    ``up_ecef`` (3,). The station's offset from the Earth's centre (8.8 arcseconds of
    parallax) is neglected."""
    sx, sy, sz = sun_unit
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    return (c * sx + s * sy) * up_ecef[0] + (c * sy - s * sx) * up_ecef[1] + sz * up_ecef[2]


def jd_split(t_s) -> tuple[np.ndarray, np.ndarray]:
    """UTC POSIX seconds as a Julian date in two parts (whole days .5, day fraction), the
    form SGP4 takes without losing precision."""
    t_s = np.asarray(t_s, dtype=float)
    days = np.floor(t_s / _DAY_S)
    return days + _UNIX_EPOCH_JD, (t_s - days * _DAY_S) / _DAY_S


def satellite_sun_flags(satrec, t_s, lat_deg: float, lon_deg: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """(sunlit, sine of the Sun's elevation at a station at geodetic ``lat_deg``,
    ``lon_deg``) at UTC POSIX seconds ``t_s`` for the SGP4 model ``satrec`` (an ``sgp4``
    ``Satrec``). A time SGP4 cannot propagate to counts as not sunlit."""
    from skyfield.sgp4lib import theta_GMST1982

    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    up_ecef = (np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat))

    jd, fr = jd_split(np.atleast_1d(t_s))
    _, r, _ = satrec.sgp4_array(jd, fr)
    sun = sun_teme_unit(jd + fr)
    dist = sun_distance_km(jd + fr)
    sun_uvw = (sun[..., 0], sun[..., 1], sun[..., 2])
    with np.errstate(invalid="ignore"):
        lit = in_sunlight((r[:, 0], r[:, 1], r[:, 2]),
                          tuple(u * dist for u in sun_uvw))
    # GMST on UTC: UT1 - UTC (under a second) moves the Sun 0.004 deg in hour angle.
    theta, _ = theta_GMST1982(jd, fr)
    return lit, sun_sin_elevation(sun_uvw, theta, up_ecef)
