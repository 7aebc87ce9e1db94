"""Synthetic passes: great circles on the sky, for property tests and forced overhead cases.

A real LEO pass is close to a great circle seen from the station, so a great circle through
a chosen culmination point exercises the same geometry (crossing a stop, through the zenith)
without orbit propagation.
"""

from __future__ import annotations

import numpy as np

from tracker.skytrack import SkyTrack, enu_to_azel

T0_S = 1_787_400_000.0  # 2026-08-22T12:00:00Z-ish: inside the bundled TLE epochs' week


def synthetic_pass(max_el_deg: float, az_cross_deg: float, duration_s: float = 600.0, *,
                   step_s: float = 1.0, pad_s: float = 60.0, clockwise: bool = True,
                   t0_s: float = T0_S, name: str = "SYNTH") -> SkyTrack:
    """A great-circle pass culminating at (``az_cross_deg``, ``max_el_deg``).

    The target moves at a constant angular rate, horizon to horizon in ``duration_s``, and
    the track is padded by ``pad_s`` below the horizon at both ends. ``clockwise`` sets the
    direction the azimuth turns at culmination. ``max_el_deg`` of 90 goes through the zenith
    (the azimuth then jumps by 180 deg there).
    """
    if not 0.0 < max_el_deg <= 90.0:
        raise ValueError("max_el_deg must be in (0, 90]")
    az = np.radians(az_cross_deg)
    el = np.radians(max_el_deg)
    a = np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    sign = 1.0 if clockwise else -1.0
    b = sign * np.array([np.sin(az + np.pi / 2), np.cos(az + np.pi / 2), 0.0])
    rate = np.pi / duration_s  # 180 deg of arc above the horizon
    t_rel = np.arange(-duration_s / 2 - pad_s, duration_s / 2 + pad_s + 1e-9, step_s)
    theta = rate * t_rel
    u = np.cos(theta)[:, None] * a + np.sin(theta)[:, None] * b
    az_deg, el_deg = enu_to_azel(u)
    return SkyTrack.from_azel(t0_s + t_rel, az_deg, el_deg, name=name,
                              max_el_deg=float(max_el_deg), az_cross_deg=float(az_cross_deg))
