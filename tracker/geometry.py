"""Mount geometry shared by the planner, the live loop and the step-table compiler.

One owner for what the three ask of a mount's pointing (numpy, with float paths for the
live loop's per-cycle calls; no I/O, no clock):

* :class:`MountPath`: a path in the mechanical frame (mechanical azimuth and mount elevation
  over time) and where the target is meanwhile. ``MountPath.from_plan`` takes a plan's
  commands as planned (the step-table compiler); ``MountPath.exact_from_plan`` the path the
  live loop follows (the plan's lead undone, exact pointing where the mode is exact).
* :func:`pointing_enu` (where a mount at mechanical az / el looks, el > 90 over the top) and
  :func:`pointing_error_deg` (the angle to the target; azimuth-only rotators are judged on
  azimuth alone, their elevation being set by hand).
* The horizon-mask guard: :func:`boresight_horizon_ok` (the test),
  :func:`raise_to_mask` (the clamp: the lowest whole step above the mask) and
  :func:`move_clears_mask` (a straight move of both axes).
* :func:`slew_s`: how long a move takes (start delay, then the slower axis).

Driving an axis through commands is the motor model's (:func:`tracker.mount.drive_axis`).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from tracker.mount import RotatorSpec
from tracker.skytrack import (
    SkyTrack,
    angle_between_components_deg,
    angle_between_deg,
    angle_between_scalar_deg,
    azel_to_enu,
    azel_to_enu_scalar,
    interp1,
    interp1_rows,
)

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.station import Station


# Unit vectors the scalar MountPath.error_deg keeps per path (each of its two memos).
_MEMO_SIZE = 256


# Where a mount points ------------------------------------------------------------------------



def az_extent_deg(band_deg: float, el_deg: ArrayLike) -> np.ndarray:
    """How far in azimuth the points within ``band_deg`` (great circle) of a target at
    ``el_deg`` reach: asin(sin band / cos el), 90 where the band holds the zenith. A point at
    the target's own elevation that far off in azimuth is a little more than the band away."""
    c = np.maximum(np.abs(np.cos(np.radians(np.asarray(el_deg, dtype=float)))), 1e-12)
    s = math.sin(math.radians(min(band_deg, 90.0)))
    return np.degrees(np.arcsin(np.minimum(s / c, 1.0)))

def pointing_enu(az_m_deg: ArrayLike, el_deg: ArrayLike,
                 stop_bearing_deg: float = 0.0) -> np.ndarray:
    """Boresight unit vectors of a mount at mechanical az / el (el > 90 points over the top)."""
    bearing = np.mod(np.asarray(az_m_deg, dtype=float) + stop_bearing_deg, 360.0)
    return azel_to_enu(bearing, el_deg)


def pointing_error_rows_deg(az_m_deg: np.ndarray, el_deg: np.ndarray, i_az: np.ndarray,
                            i_el: np.ndarray, stop_bearing_deg: float,
                            target_enu: np.ndarray) -> np.ndarray:
    """``angle_between_deg(pointing_enu(az_m_deg[i_az], el_deg[i_el], stop_bearing_deg),
    target_enu)`` (the same values) for mounts that pair an azimuth row with an elevation
    row: the trigonometry is done once per row, not once per pair (the aim policy's candidates
    share a few targets per axis)."""
    bearing = az_m_deg + stop_bearing_deg
    # np.mod's value where all are above 0 is np.fmod's, at a third of its cost (mechanical
    # azimuths are >= 0 within the axis limits)
    b = np.radians(np.fmod(bearing, 360.0) if bearing.min() > 0.0 else np.mod(bearing, 360.0))
    e = np.radians(el_deg)
    ce = np.cos(e)[i_el]
    t = np.asarray(target_enu, dtype=float)
    return angle_between_components_deg(ce * np.sin(b)[i_az], ce * np.cos(b)[i_az],
                                        np.sin(e)[i_el], t[..., 0], t[..., 1], t[..., 2])


def pointing_error_deg(spec: RotatorSpec, ant_az_m_deg: float | ArrayLike,
                       ant_el_deg: float | ArrayLike | None,
                       target: np.ndarray | tuple[float | ArrayLike, float | ArrayLike]) -> Any:
    """Angle between where a mount at (mechanical az, el) points and the target.

    ``target`` is either east-north-up unit vectors (shape ``(..., 3)``) or a pair
    ``(bearing_deg, el_deg)``. Great-circle angle for az/el rotators (el > 90 points over the
    top); for azimuth-only rotators (or ``ant_el_deg`` None) the azimuth difference alone,
    since the beam's elevation is not steerable. Broadcasts over leading axes; floats (az, el
    and a ``(bearing, el)`` pair) take a scalar path and give a float.
    """
    if isinstance(ant_az_m_deg, float) and isinstance(target, tuple) and isinstance(
            target[0], float) and isinstance(target[1], float) and (
            ant_el_deg is None or isinstance(ant_el_deg, float)):
        return look_error_deg(mount_look(spec, ant_az_m_deg, ant_el_deg), target[0], target[1])
    bearing = spec.bearing_of(ant_az_m_deg)
    if isinstance(target, tuple):
        target_az = np.asarray(target[0], dtype=float)
        if not spec.has_elevation or ant_el_deg is None:
            return np.abs(np.mod(bearing - target_az + 180.0, 360.0) - 180.0)
        target_enu = azel_to_enu(target_az, target[1])
    else:
        target_enu = np.asarray(target, dtype=float)
        if not spec.has_elevation or ant_el_deg is None:
            target_az = np.degrees(np.arctan2(target_enu[..., 0], target_enu[..., 1]))
            return np.abs(np.mod(bearing - target_az + 180.0, 360.0) - 180.0)
    return angle_between_deg(azel_to_enu(bearing, ant_el_deg), target_enu)


MountLook = tuple[float, tuple[float, float, float] | None]


def mount_look(spec: RotatorSpec, ant_az_m_deg: float, ant_el_deg: float | None) -> MountLook:
    """What :func:`pointing_error_deg` needs of a mount at floats (mechanical az, el): its
    true bearing and boresight unit vector (None where azimuth alone is judged). Kept by a
    caller that asks about the same antenna position cycle after cycle."""
    b = spec.bearing_of(ant_az_m_deg)
    if not spec.has_elevation or ant_el_deg is None:
        return b, None
    return b, azel_to_enu_scalar(b, ant_el_deg)


def look_error_deg(look: MountLook, target_az_deg: float, target_el_deg: float) -> float:
    """:func:`pointing_error_deg` on floats, from the mount's :func:`mount_look`."""
    b, here = look
    if here is None:
        return abs((b - target_az_deg + 180.0) % 360.0 - 180.0)
    return angle_between_scalar_deg(here, azel_to_enu_scalar(target_az_deg, target_el_deg))


# The horizon mask ----------------------------------------------------------------------------


def boresight_look(spec: RotatorSpec, m_az_deg: ArrayLike, el_deg: ArrayLike
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Where the boresight really looks, ``(bearing in [0, 360), elevation <= 90)``: over
    the top (el > 90) a mount looks at bearing + 180, elevation 180 - el."""
    b = spec.bearing_of(m_az_deg)
    e = np.asarray(el_deg, dtype=float)
    over = e > 90.0
    return np.mod(np.where(over, b + 180.0, b), 360.0), np.where(over, 180.0 - e, e)


def boresight_horizon_ok(spec: RotatorSpec, station: Station, m_az_deg: ArrayLike,
                         el_deg: ArrayLike, tol_deg: float = 1e-6) -> np.ndarray:
    """True where a mount position points at or above the station's horizon mask
    (always for an azimuth-only rotator)."""
    m = np.asarray(m_az_deg, dtype=float)
    if not spec.has_elevation:
        return np.ones(np.shape(m), dtype=bool)
    look_b, look_e = boresight_look(spec, m, el_deg)
    return look_e >= np.asarray(station.horizon_at(look_b)) - tol_deg


def raise_to_mask(spec: RotatorSpec, station: Station, m_az_deg: float | ArrayLike,
                  el_deg: float | ArrayLike, step_deg: float | None = None) -> Any:
    """Elevations moved just clear of the horizon mask where the boresight is below it.

    A position below the mask gets the lowest whole ``step_deg`` (default: the spec's
    resolution) at or above it: raised, or for a mount over the top (el > 90) lowered to
    ``180 - step``. Positions on or above the mask are returned unchanged; so are all of an
    azimuth-only rotator's. The caller clamps the result to its own limits.
    """
    res = spec.resolution_deg if step_deg is None else step_deg
    if isinstance(m_az_deg, float) and isinstance(el_deg, float) and spec.has_elevation:
        # One command (the live loop's last guard): the same test and step on floats.
        b = spec.bearing_of(m_az_deg)
        over = el_deg > 90.0
        look_b = (b + 180.0) % 360.0 if over else b % 360.0
        floor_deg = float(station.horizon_at(look_b))
        if (180.0 - el_deg if over else el_deg) >= floor_deg - 1e-9:
            return el_deg
        step_up = math.ceil(floor_deg / res - 1e-9) * res
        return 180.0 - step_up if over else step_up
    e = np.asarray(el_deg, dtype=float)
    if not spec.has_elevation:
        return e.copy()
    look_b, _look_e = boresight_look(spec, m_az_deg, e)
    floor = np.asarray(station.horizon_at(look_b))
    safe_look = np.ceil(floor / res - 1e-9) * res
    below = ~boresight_horizon_ok(spec, station, m_az_deg, e, tol_deg=1e-9)
    return np.where(below, np.where(e > 90.0, 180.0 - safe_look, safe_look), e)


def move_clears_mask(spec: RotatorSpec, station: Station, start: tuple[float, float | None],
                     end: tuple[float, float | None], samples: int = 64) -> bool:
    """True if both axes, started together from ``start`` at their own rates, keep the
    boresight on or above the horizon mask all the way to ``end`` (mechanical az, el)."""
    if not spec.has_elevation or start[1] is None or end[1] is None:
        return True
    (m0, e0), (m1, e1) = start, end
    assert e0 is not None and e1 is not None
    t_end = max(abs(m1 - m0) / spec.az_rate_deg_s, abs(e1 - e0) / spec.el_rate)
    t = np.linspace(0.0, t_end, samples)
    m = m0 + np.sign(m1 - m0) * np.minimum(t * spec.az_rate_deg_s, abs(m1 - m0))
    e = e0 + np.sign(e1 - e0) * np.minimum(t * spec.el_rate, abs(e1 - e0))
    return bool(np.all(boresight_horizon_ok(spec, station, m, e)))


# Slew time -----------------------------------------------------------------------------------


def slew_s(spec: RotatorSpec, from_az_m_deg: float | Sequence[float], from_el_deg: float | None,
           to_az_m_deg: float | Sequence[float], to_el_deg: float | None) -> float:
    """Time to turn from one mechanical (az, el) to another: start delay + the slower axis.

    An azimuth may be a list of mechanical candidates (``spec.frame.mech_candidates(bearing)``: an
    antenna in the overlap of a 450 deg rotator); the closest pair counts. Elevation counts
    on a rotator with elevation when both are given.
    """
    a = list(from_az_m_deg) if isinstance(from_az_m_deg, Sequence) else [float(from_az_m_deg)]
    b = list(to_az_m_deg) if isinstance(to_az_m_deg, Sequence) else [float(to_az_m_deg)]
    daz = min(abs(x - y) for x in a for y in b)
    t = daz / spec.az_rate_deg_s
    if spec.has_elevation and from_el_deg is not None and to_el_deg is not None:
        t = max(t, abs(to_el_deg - from_el_deg) / spec.el_rate)
    return spec.start_delay_s + t


# The mount path ------------------------------------------------------------------------------


@dataclass(frozen=True)
class MountPath:
    """Where the antenna should point, in the mechanical frame, and where the target is.

    ``az_m_deg`` is mechanical azimuth (continuous, overlap and flip included), ``el_deg`` the
    mount elevation (> 90 on a flip path; ``None`` for an azimuth-only rotator), at ``t_s``
    (UTC POSIX seconds). ``sky_enu`` (shape ``(n, 3)``) is where the target is: keyhole,
    unwind and ahead paths are approximations, and the error that matters is the error to the
    target, not to the path; ``None`` means the path itself is the target.
    """

    t_s: np.ndarray
    az_m_deg: np.ndarray
    el_deg: np.ndarray | None
    stop_bearing_deg: float = 0.0
    sky_enu: np.ndarray | None = None
    name: str = ""
    meta: dict = field(default_factory=dict, compare=False)

    @classmethod
    def from_arrays(cls, t_s: ArrayLike, az_m_deg: ArrayLike, el_deg: ArrayLike | None,
                    spec: RotatorSpec) -> MountPath:
        """A path that is its own target (tests, hand-made paths)."""
        el = None if el_deg is None else np.asarray(el_deg, dtype=float)
        return cls(np.asarray(t_s, dtype=float), np.asarray(az_m_deg, dtype=float), el,
                   float(spec.stop_bearing_deg))

    @classmethod
    def from_plan(cls, plan: Any, track: SkyTrack, spec: RotatorSpec) -> MountPath:
        """A planner :class:`~tracker.planner.MountPlan`'s commands as planned (quantised,
        led as planned) and the target of the :class:`SkyTrack` it was planned for."""
        t = np.asarray(plan.t_s, dtype=float)
        el = None if not spec.has_elevation else np.asarray(plan.cmd_el_deg, dtype=float)
        return cls(t, np.asarray(plan.cmd_az_deg, dtype=float), el,
                   float(spec.stop_bearing_deg), azel_to_enu(*track.direction_at(t)),
                   getattr(track, "name", ""), dict(getattr(track, "meta", {}) or {}))

    @classmethod
    def exact_from_plan(cls, plan: Any, track: SkyTrack | None,
                        spec: RotatorSpec) -> MountPath:
        """The path the live loop follows for a plan (``track``: None for the plan's own).

        The plan's commands are quantised and already led by ``plan.lead_s``; the aim policy
        does its own lead, so the lead is undone. Where the target is visible in an exact mode
        (normal, overlap, flip) the path is the exact mechanical pointing at the target on the
        plan's branch (no 1-degree staircase); keyhole, unwind and ahead paths are
        approximations by design and are followed as planned.
        """
        t = np.asarray(plan.t_s, dtype=float)
        lead = float(getattr(plan, "lead_s", 0.0) or 0.0)
        az = np.interp(t - lead, t, np.asarray(plan.cmd_az_deg, dtype=float))
        el_cmd = getattr(plan, "cmd_el_deg", None)
        el = (None if not spec.has_elevation else np.zeros_like(t) if el_cmd is None
              else np.interp(t - lead, t, np.asarray(el_cmd, dtype=float)))
        track = track if track is not None else getattr(plan, "track", None)
        if track is None or len(track) != len(t):
            return cls(t, az, el, float(spec.stop_bearing_deg))
        vis = np.asarray(getattr(plan, "visible", track.el_deg >= 0.0), dtype=bool)
        mode = str(getattr(plan, "mode", "normal"))
        if mode in ("normal", "overlap", "flip"):
            flip = mode == "flip"
            bearing = np.mod(track.az_deg + (180.0 if flip else 0.0), 360.0)
            exact_m = az + (np.mod(spec.mech_of(bearing) - az + 180.0, 360.0) - 180.0)
            az = np.where(vis, np.clip(exact_m, 0.0, spec.az_span_deg), az)
            if el is not None:
                exact_e = 180.0 - track.el_deg if flip else track.el_deg
                el = np.where(vis, np.clip(exact_e, spec.el_min_deg, spec.el_max_deg), el)
        sky = None
        if vis.any():
            # An azimuth-only rotator is judged on azimuth alone (as its plan is).
            sky_el = track.el_deg if spec.has_elevation else np.zeros_like(t)
            own_el = np.zeros_like(t) if el is None else el
            sky = np.where(vis[:, None], azel_to_enu(track.az_deg, sky_el),
                           pointing_enu(az, own_el, spec.stop_bearing_deg))
        return cls(t, az, el, float(spec.stop_bearing_deg), sky)

    @classmethod
    def from_track(cls, track: SkyTrack, spec: RotatorSpec) -> MountPath:
        """The plain unwrapped path (no flip): for tests and when no planner is at hand.

        The unwrapped mechanical azimuth is shifted by whole turns so it fits the span if it
        can (a 450° rotator then uses its overlap), else clipped.
        """
        t = np.asarray(track.t_s, dtype=float)
        m = np.degrees(np.unwrap(np.radians(spec.mech_of(track.az_deg))))
        best = m
        for k in range(-2, 3):
            cand = m + 360.0 * k
            lo, hi = cand.min(), cand.max()
            if lo >= 0.0 and hi <= spec.az_span_deg:
                best = cand
                break
            if k == 0:
                best = cand - 360.0 * np.floor(lo / 360.0)
        m = np.clip(best, 0.0, spec.az_span_deg)
        el = None
        if spec.has_elevation:
            el = np.clip(np.asarray(track.el_deg, dtype=float), spec.el_min_deg,
                         spec.el_max_deg)
        return cls(t, m, el, float(spec.stop_bearing_deg),
                   azel_to_enu(np.asarray(track.az_deg, dtype=float),
                               np.asarray(track.el_deg, dtype=float)),
                   getattr(track, "name", ""), dict(getattr(track, "meta", {}) or {}))

    @property
    def start_s(self) -> float:
        return float(self.t_s[0])

    @property
    def end_s(self) -> float:
        return float(self.t_s[-1])

    @cached_property
    def _columns(self) -> tuple[list[float], list[float], list[float] | None,
                                list[list[float]] | None]:
        """``t_s``, ``az_m_deg``, ``el_deg`` and the target's rows as lists, for
        :func:`~tracker.skytrack.interp1` and :func:`~tracker.skytrack.interp1_rows`."""
        el = None if self.el_deg is None else self.el_deg.tolist()
        sky = None if self.sky_enu is None else self.sky_enu.tolist()
        return self.t_s.tolist(), self.az_m_deg.tolist(), el, sky

    def error_deg(self, t_s: float | np.ndarray, az_m_deg: float | ArrayLike,
                  el_deg: float | ArrayLike) -> Any:
        """Great-circle angle between a mount at mechanical ``az_m_deg`` / ``el_deg`` and
        where the target is at ``t_s`` (:meth:`target_enu`); arrays broadcast, and floats take
        a scalar path (the live loop's per-cycle checks) that gives a float."""
        if isinstance(t_s, float) and isinstance(az_m_deg, float) and isinstance(
                el_deg, float):
            targets = self._scalar_memo[1]
            here = self._mount_enu(az_m_deg, el_deg)
            there = targets.get(t_s)
            if there is None:
                there = self._target_enu_scalar(t_s)
                if len(targets) >= _MEMO_SIZE:
                    targets.clear()
                targets[t_s] = there
            return angle_between_scalar_deg(here, there)
        return angle_between_deg(pointing_enu(az_m_deg, el_deg, self.stop_bearing_deg),
                                 self.target_enu(t_s))

    def _mount_enu(self, az_m_deg: float, el_deg: float) -> tuple[float, float, float]:
        """The boresight unit vector of a mount at floats (kept in :attr:`_scalar_memo`)."""
        looks = self._scalar_memo[0]
        here = looks.get((az_m_deg, el_deg))
        if here is None:
            here = azel_to_enu_scalar((az_m_deg + self.stop_bearing_deg) % 360.0, el_deg)
            if len(looks) >= _MEMO_SIZE:
                looks.clear()
            looks[az_m_deg, el_deg] = here
        return here

    @cached_property
    def _scalar_memo(self) -> tuple[dict[tuple[float, float], tuple[float, float, float]],
                                    dict[float, tuple[float, float, float]]]:
        """The scalar :meth:`error_deg`'s unit vectors already computed: of mount positions
        (an axis at rest is asked about at the same place many times) and of the target at
        float times (consecutive cycles ask about the same instants ahead). The same values
        as computing them again."""
        return {}, {}

    @cached_property
    def _travel_cum_deg(self) -> list[float]:
        """Per sample, an upper bound on the angle the target has moved since the first one:
        between two samples it moves along the arc between them (the target interpolated on
        the sphere), or by at most its az and el steps (the path's own pointing)."""
        if self.sky_enu is not None:
            step = angle_between_deg(self.sky_enu[:-1], self.sky_enu[1:])
        else:
            step = np.abs(np.diff(self.az_m_deg))
            if self.el_deg is not None:
                step = step + np.abs(np.diff(self.el_deg))
        return np.concatenate(([0.0], np.cumsum(step))).tolist()

    def target_travel_bound_deg(self, t0_s: float, t1_s: float) -> float:
        """An upper bound on the angle the target (:meth:`target_enu`) moves between
        ``t0_s`` and ``t1_s`` (``t0_s <= t1_s``): the whole sample intervals they touch."""
        ts = self._columns[0]
        last = len(ts) - 2
        if last < 0:
            return 0.0
        j0 = min(max(bisect_right(ts, t0_s) - 1, 0), last)
        j1 = min(max(bisect_right(ts, t1_s) - 1, 0), last)
        cum = self._travel_cum_deg
        return cum[j1 + 1] - cum[j0]

    def fixed_mount_within_s(self, az_m_deg: float, el_deg: float, t0_s: float,
                             limit_deg: float, stop_s: float) -> float:
        """How long a mount standing still at ``az_m_deg``, ``el_deg`` stays within
        ``limit_deg`` of the target from ``t0_s`` on, by a bound: every error between
        ``t0_s`` and the time returned is at most ``limit_deg`` (``t0_s`` itself when not even
        the error now is shown so; inf past the path's end or once ``stop_s`` is reached).

        Between two samples the target moves along the arc between them (or by at most its
        az and el steps, :meth:`target_travel_bound_deg`), so within the interval its error
        from a fixed point is at most half the sum of the errors at both ends and the arc:
        each interval is bounded by its ends' errors, not by all the travel since ``t0_s``."""
        ts = self._columns[0]
        cum = self._travel_cum_deg
        last = len(ts) - 1
        j = bisect_right(ts, t0_s) - 1
        if j >= last:           # past the last sample the target stands still
            return math.inf if self.error_deg(t0_s, az_m_deg, el_deg) <= limit_deg else t0_s
        start_s, err_a = t0_s, self.error_deg(t0_s, az_m_deg, el_deg)
        j = max(j, 0)           # before the first sample the target stands at it
        # The samples' errors from this mount position, kept while it is asked about (a
        # mount at rest is, cycle after cycle).
        memo = self._fixed_errors
        if memo[0] != (az_m_deg, el_deg):
            memo[0] = (az_m_deg, el_deg)
            memo[1].clear()
        errs = memo[1]
        here = None
        while j < last:
            t_b = ts[j + 1]
            err_b = errs.get(j + 1)
            if err_b is None:
                # error_deg at the sample's own time, from the sample itself
                if here is None:
                    here = self._mount_enu(az_m_deg, el_deg)
                err_b = errs[j + 1] = angle_between_scalar_deg(here, self._sample_enu(j + 1))
            if 0.5 * (err_a + err_b + (cum[j + 1] - cum[j])) > limit_deg:
                return start_s
            if t_b >= stop_s:
                return math.inf
            start_s, err_a = t_b, err_b
            j += 1
        return math.inf

    @cached_property
    def _fixed_errors(self) -> list:
        """``[(az, el), {sample index: error}]`` of :meth:`fixed_mount_within_s`'s last mount
        position."""
        return [None, {}]

    def _sample_enu(self, j: int) -> tuple[float, float, float]:
        """:meth:`_target_enu_scalar` at the time of sample ``j`` (kept once computed)."""
        dirs = self._sample_dirs
        v = dirs[j]
        if v is None:
            v = dirs[j] = self._target_enu_scalar(self._columns[0][j])
        return v

    @cached_property
    def _sample_dirs(self) -> list[tuple[float, float, float] | None]:
        return [None] * len(self.t_s)

    def _target_enu_scalar(self, t_s: float) -> tuple[float, float, float]:
        """:meth:`target_enu` at one float time, on floats."""
        ts, az, el, sky = self._columns
        if sky is None:
            e = 0.0 if el is None else interp1(t_s, ts, el)
            return azel_to_enu_scalar((interp1(t_s, ts, az) + self.stop_bearing_deg) % 360.0,
                                      e)
        x, y, z = interp1_rows(t_s, ts, sky)
        norm = math.sqrt(x * x + y * y + z * z)
        return x / norm, y / norm, z / norm

    def mount_at(self, t_s: float | np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Mechanical az and mount el at ``t_s`` (linear: the mechanical frame has no wrap;
        el None for an azimuth-only path)."""
        az = np.interp(t_s, self.t_s, self.az_m_deg)
        el = None if self.el_deg is None else np.interp(t_s, self.t_s, self.el_deg)
        return az, el

    def target_enu(self, t_s: float | np.ndarray) -> np.ndarray:
        """Where the target is at ``t_s`` (east-north-up unit vectors, shape ``(..., 3)``,
        interpolated on the sphere, wrap-safe); the path's own pointing without a target."""
        if self.sky_enu is None:
            az, el = self.mount_at(t_s)
            return pointing_enu(az, np.zeros_like(az) if el is None else el,
                                self.stop_bearing_deg)
        v = np.empty((*np.shape(t_s), 3))
        for k, col in enumerate(self._sky_columns):
            v[..., k] = np.interp(t_s, self.t_s, col)
        # np.linalg.norm's own arithmetic for a vector norm, without its checks
        return v / np.sqrt(np.add.reduce(v * v, axis=-1, keepdims=True))

    @cached_property
    def _sky_columns(self) -> tuple[np.ndarray, ...]:
        """The target's east, north, up columns, contiguous (np.interp copies a strided
        column on every call)."""
        assert self.sky_enu is not None
        return tuple(np.ascontiguousarray(self.sky_enu[:, k]) for k in range(3))

