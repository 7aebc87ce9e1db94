"""SkyTrack: where a target is in the sky, sampled over time (plain numpy arrays)."""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from functools import cached_property

import numpy as np

from tracker.timescale import to_datetime


@dataclass(frozen=True)
class SkyTrack:
    """Topocentric samples of one target as seen from one station.

    All arrays have the same shape ``(n,)``. ``t_s`` is UTC POSIX seconds, strictly
    increasing; ``az_deg`` is the true bearing in [0, 360); ``el_deg`` the elevation above the
    horizontal (not the mask). ``range_km``, ``range_rate_km_s`` and ``sunlit`` may be NaN /
    False for targets where they mean nothing (a schedule file, a radio source).
    """

    t_s: np.ndarray
    az_deg: np.ndarray
    el_deg: np.ndarray
    range_km: np.ndarray
    range_rate_km_s: np.ndarray
    sunlit: np.ndarray
    name: str = ""
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        n = np.shape(self.t_s)
        for key in ("az_deg", "el_deg", "range_km", "range_rate_km_s", "sunlit"):
            if np.shape(getattr(self, key)) != n:
                raise ValueError(f"SkyTrack.{key} has shape {np.shape(getattr(self, key))}, "
                                 f"expected {n}")
        if len(self.t_s) > 1 and not np.all(np.diff(self.t_s) > 0):
            raise ValueError("SkyTrack.t_s must be strictly increasing")

    def __len__(self) -> int:
        return len(self.t_s)

    @classmethod
    def from_azel(cls, t_s, az_deg, el_deg, name: str = "", **meta) -> SkyTrack:
        """A track with only direction information (range and sunlit unknown)."""
        t_s = np.asarray(t_s, dtype=float)
        nan = np.full(t_s.shape, np.nan)
        return cls(t_s, np.mod(np.asarray(az_deg, dtype=float), 360.0),
                   np.asarray(el_deg, dtype=float), nan, nan.copy(),
                   np.zeros(t_s.shape, dtype=bool), name, dict(meta))

    @property
    def start(self) -> datetime:
        return to_datetime(self.t_s[0])

    @property
    def end(self) -> datetime:
        return to_datetime(self.t_s[-1])

    def unit_vectors(self) -> np.ndarray:
        """East-north-up unit vectors, shape ``(n, 3)``."""
        return azel_to_enu(self.az_deg, self.el_deg)

    @cached_property
    def _sampled(self) -> tuple[list[float], list[list[float]]]:
        """``t_s`` and the unit vectors as lists, for :func:`interp1_rows`."""
        return self.t_s.tolist(), self.unit_vectors().tolist()

    def direction_at(self, t_s) -> tuple[np.ndarray, np.ndarray]:
        """Az/el at arbitrary times, interpolated on the unit sphere (safe across 0/360).

        A float time takes a scalar path (floats back): the live loop asks once a cycle."""
        if isinstance(t_s, float):
            ts, rows = self._sampled
            e, n, u = interp1_rows(t_s, ts, rows)
            return (math.degrees(math.atan2(e, n)) % 360.0,  # type: ignore[return-value]
                    math.degrees(math.atan2(u, math.hypot(e, n))))
        t_s = np.asarray(t_s, dtype=float)
        v = self.unit_vectors()
        enu = np.stack([np.interp(t_s, self.t_s, v[:, i]) for i in range(3)], axis=-1)
        return enu_to_azel(enu)

    def slice_time(self, t0_s: float, t1_s: float) -> SkyTrack:
        keep = (self.t_s >= t0_s) & (self.t_s <= t1_s)
        return SkyTrack(self.t_s[keep], self.az_deg[keep], self.el_deg[keep],
                        self.range_km[keep], self.range_rate_km_s[keep], self.sunlit[keep],
                        self.name, dict(self.meta))


def azel_to_enu(az_deg, el_deg) -> np.ndarray:
    """Unit vectors (east, north, up) for bearings/elevations in degrees; shape ``(..., 3)``.

    Elevations above 90° (a flipped mount) are handled: they point over the top.
    """
    az = np.radians(np.asarray(az_deg, dtype=float))
    el = np.radians(np.asarray(el_deg, dtype=float))
    ce = np.cos(el)
    return np.stack([ce * np.sin(az), ce * np.cos(az), np.sin(el)], axis=-1)


def interp1(x: float, xp: Sequence[float], fp: Sequence[float]) -> float:
    """``np.interp(x, xp, fp)`` for one float on lists, with numpy's arithmetic (bisect,
    then the same lerp): per-cycle look-ups, where a numpy call costs more than the work."""
    if x != x or x < xp[0]:
        return x if x != x else fp[0]
    j = bisect_right(xp, x) - 1
    if j >= len(xp) - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


def interp1_rows(x: float, xp: Sequence[float], rows: Sequence[Sequence[float]]
                 ) -> list[float]:
    """:func:`interp1` of every column of ``rows`` (one row per ``xp``), one bisect for all."""
    if x != x:
        return [x] * len(rows[0])
    if x < xp[0]:
        return list(rows[0])
    j = bisect_right(xp, x) - 1
    if j >= len(xp) - 1 or xp[j] == x:
        return list(rows[j])
    dx, u = xp[j + 1] - xp[j], x - xp[j]
    r0, r1 = rows[j], rows[j + 1]
    if len(r0) == 3:    # unit vectors, once or more a cycle: no generator
        return [(r1[0] - r0[0]) / dx * u + r0[0], (r1[1] - r0[1]) / dx * u + r0[1],
                (r1[2] - r0[2]) / dx * u + r0[2]]
    return [(b - a) / dx * u + a for a, b in zip(r0, r1, strict=True)]


def azel_to_enu_scalar(az_deg: float, el_deg: float) -> tuple[float, float, float]:
    """:func:`azel_to_enu` of one direction, on floats (the live loop's per-cycle checks)."""
    az = math.radians(az_deg)
    el = math.radians(el_deg)
    ce = math.cos(el)
    return ce * math.sin(az), ce * math.cos(az), math.sin(el)


def angle_between_scalar_deg(a: Sequence[float], b: Sequence[float]) -> float:
    """:func:`angle_between_deg` of two unit vectors given as float triples (numpy's order of
    operations, so both agree to rounding of the trigonometric functions)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    c0 = a1 * b2 - a2 * b1
    c1 = a2 * b0 - a0 * b2
    c2 = a0 * b1 - a1 * b0
    cross = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    dot = a0 * b0 + a1 * b1 + a2 * b2
    return math.degrees(math.atan2(cross, dot))


def enu_to_azel(enu) -> tuple[np.ndarray, np.ndarray]:
    enu = np.asarray(enu, dtype=float)
    e, n, u = enu[..., 0], enu[..., 1], enu[..., 2]
    az = np.mod(np.degrees(np.arctan2(e, n)), 360.0)
    el = np.degrees(np.arctan2(u, np.hypot(e, n)))
    return az, el


def angle_between_deg(a, b) -> np.ndarray:
    """Great-circle angle between unit vectors (last axis 3), robust near 0 and 180."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return angle_between_components_deg(a[..., 0], a[..., 1], a[..., 2],
                                        b[..., 0], b[..., 1], b[..., 2])


def angle_between_components_deg(a0, a1, a2, b0, b1, b2) -> np.ndarray:
    """:func:`angle_between_deg` of vectors given as their east, north, up components
    (broadcast): no ``(..., 3)`` arrays to build when the components are at hand."""
    c0 = a1 * b2 - a2 * b1
    c1 = a2 * b0 - a0 * b2
    c2 = a0 * b1 - a1 * b0
    cross = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    return np.degrees(np.arctan2(cross, a0 * b0 + a1 * b1 + a2 * b2))


def angular_separation_deg(az1_deg, el1_deg, az2_deg, el2_deg) -> np.ndarray:
    """Great-circle angle between two directions (el may exceed 90 for flipped pointing)."""
    return angle_between_deg(azel_to_enu(az1_deg, el1_deg), azel_to_enu(az2_deg, el2_deg))


COMPASS_POINTS = ("N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE",
                  "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW")


def compass_index(az_deg) -> np.ndarray:
    """The index into :data:`COMPASS_POINTS` of bearings (an int array, or an int array
    of no dimensions for one bearing)."""
    return ((np.mod(np.asarray(az_deg, dtype=float), 360.0) + 11.25) // 22.5).astype(int) % 16


def compass_point(az_deg):
    """16-point compass name (N, NNE, NE, ... NNW) of a bearing; for an array of bearings,
    an array of names."""
    index = compass_index(az_deg)
    if np.ndim(index) == 0:
        return COMPASS_POINTS[int(index)]
    return np.array(COMPASS_POINTS, dtype=object)[index]
