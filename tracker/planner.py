"""Mount-path planner: choose how the rotator follows one pass, and predict how well it does.

Input is a :class:`~tracker.skytrack.SkyTrack` padded before AOS and after LOS, a
:class:`~tracker.mount.RotatorSpec`, the station (minimum elevation + horizon mask) and the
antenna's current position. Every candidate path is built as numpy arrays over the track
samples, quantised to the command resolution, clamped to the limits and the mask, driven
through THE motor model (:func:`tracker.mount.drive_axis`) and scored by the great-circle
angle between boresight and target. The best one becomes the :class:`MountPlan`.

Candidates (the stop-avoiding and zenith strategies trackers use, all scored alike):

* ``normal`` / ``overlap``: the unwrapped mechanical azimuth shifted by k*360 so the whole
  pass fits the span. On a 450 deg rotator a shift that uses mechanical 360-450 is reported as
  ``overlap`` -- that is how the overlap avoids a mid-pass unwind.
* ``flip``: (az + 180, 180 - el) for the whole pass, also shifted to fit. With el max < 180
  the low ends are clamped and the error counted (no all-or-nothing rule as in Gpredict).
* ``keyhole``: for near-overhead passes, azimuth held near the along-track bearing while
  elevation sweeps 0 -> 180, with a bounded azimuth correction; several bounds are tried.
* ``unwind``: when nothing fits, the 360 deg swing is placed where it loses least.
* ``ahead``: when every other candidate loses the target (a near-overhead pass whose
  azimuth turns faster than the rotator near culmination), the azimuth turns *ahead* of the
  target: the path keeps within a band of it at a share of the rotator's rate, starting the
  turn early (:func:`rate_limited_within`), upright or over the top; several bands and
  shares are tried.

Ranking: lost-track seconds, then max error (in command-resolution steps), then travel
from the current position, then motor starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np

from tracker.errors import LimitError
from tracker.geometry import az_extent_deg, pointing_error_deg, raise_to_mask, slew_s
from tracker.mount import AxisMotor, RotatorSpec, drive_axis
from tracker.skytrack import SkyTrack, angle_between_deg, azel_to_enu
from tracker.station import Station

LOST_THRESHOLD_DEG = 5.0  # half the beamwidth of a typical satellite yagi
KEYHOLE_MIN_EL_DEG = 60.0
KEYHOLE_CAPS_DEG = (0.0, 15.0, 40.0, 70.0)
# The ahead path's azimuth keeps within a band of the target (deg of great circle) at a share of
# the rotator's rate: what is left of the 5 deg and of the rate absorbs the start delay, the
# 1 deg steps and the lead. On the pass suite's lossy passes no single pair kept them all.
AHEAD_BANDS_DEG = (4.0, 4.5, 4.8)
AHEAD_RATE_SHARES = (0.8, 0.9, 1.0)
PREPOSITION_MARGIN_S = 10.0


@dataclass(frozen=True)
class Move:
    """One timed command outside tracking (pre-position or park), mechanical degrees."""

    t_s: float
    az_deg: float
    el_deg: float


@dataclass(frozen=True)
class CandidateScore:
    """Every figure of one candidate path, as ranked."""

    mode: str
    fits: bool  # the exact path lies inside the limits without clamping
    lost_track_s: float
    max_error_deg: float
    mean_error_deg: float
    p99_error_deg: float
    travel_deg: float  # including the pre-position move from the current position
    motor_starts: int
    note: str = ""

    def rank_key(self, resolution_deg: float = 1.0) -> tuple:
        return (round(self.lost_track_s, 3), math.ceil(self.max_error_deg / resolution_deg - 1e-9),
                round(self.travel_deg, 1), self.motor_starts)

    def as_dict(self) -> dict:
        return {"mode": self.mode, "fits": self.fits, "lost_track_s": self.lost_track_s,
                "max_error_deg": self.max_error_deg, "mean_error_deg": self.mean_error_deg,
                "p99_error_deg": self.p99_error_deg, "travel_deg": self.travel_deg,
                "motor_starts": self.motor_starts, "note": self.note}


@dataclass(frozen=True)
class MountPlan:
    """The chosen path for one pass and its predicted performance.

    Arrays have the track's shape ``(n,)``: ``cmd_az_deg``/``cmd_el_deg`` are the commanded
    mechanical azimuth and elevation (quantised, within limits and mask; elevation above 90
    means over the top), ``ant_az_deg``/``ant_el_deg`` the predicted antenna position after
    rate-limited motion, ``error_deg`` the great-circle angle between boresight and target
    (azimuth difference only for azimuth-only rotators), ``visible`` where the target is above
    the station's horizon mask. Statistics are over visible samples.
    """

    track: SkyTrack
    spec: RotatorSpec
    mode: str
    reason: str
    t_s: np.ndarray
    cmd_az_deg: np.ndarray
    cmd_el_deg: np.ndarray
    ant_az_deg: np.ndarray
    ant_el_deg: np.ndarray
    error_deg: np.ndarray
    visible: np.ndarray
    candidates: tuple[CandidateScore, ...]
    preposition_t_s: float
    preposition: tuple[float, float]
    preposition_moves: tuple[Move, ...]
    park_moves: tuple[Move, ...]
    max_error_deg: float
    mean_error_deg: float
    p99_error_deg: float
    lost_track_s: float
    travel_deg: float
    motor_starts: int
    threshold_deg: float = LOST_THRESHOLD_DEG
    lead_s: float = 0.0
    meta: dict = field(default_factory=dict, compare=False)

    @property
    def chosen(self) -> CandidateScore:
        return self.candidates[0]

    def commands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t_s, az_deg, el_deg) at every sample where the quantised command changes."""
        change = np.ones(len(self.t_s), dtype=bool)
        change[1:] = (np.diff(self.cmd_az_deg) != 0) | (np.diff(self.cmd_el_deg) != 0)
        return self.t_s[change], self.cmd_az_deg[change], self.cmd_el_deg[change]

    def summary(self) -> dict:
        """Plain values for batch tables, CSV and JSON export."""
        vis_t = self.t_s[self.visible]

        def iso(t: float) -> str:
            return datetime.fromtimestamp(float(t), timezone.utc).isoformat()

        return {
            "target": self.track.name, "rotator": self.spec.name, "mode": self.mode,
            "reason": self.reason, "aos": iso(vis_t[0]), "los": iso(vis_t[-1]),
            "max_el_deg": round(float(np.max(self.track.el_deg[self.visible])), 2),
            "preposition_at": iso(self.preposition_t_s),
            "preposition_az_deg": self.preposition[0],
            "preposition_el_deg": self.preposition[1],
            "max_error_deg": round(self.max_error_deg, 3),
            "mean_error_deg": round(self.mean_error_deg, 3),
            "p99_error_deg": round(self.p99_error_deg, 3),
            "lost_track_s": round(self.lost_track_s, 1), "travel_deg": round(self.travel_deg, 1),
            "motor_starts": self.motor_starts,
            "candidates": [c.as_dict() for c in self.candidates],
        }


# Geometry helpers --------------------------------------------------------------------------


def park_position(spec: RotatorSpec, station: Station) -> tuple[float, float]:
    """Where the antenna parks: the spec's (mechanical az, el), the elevation raised to the
    horizon mask there (whole resolution steps), so parking never points below it."""
    park_el = spec.park_el_deg if spec.has_elevation else 0.0
    if spec.has_elevation:
        floor = float(station.horizon_at(spec.bearing_of(spec.park_az_deg)))
        park_el = max(park_el, math.ceil(floor / spec.resolution_deg - 1e-9)
                      * spec.resolution_deg)
        park_el = min(park_el, spec.el_top_deg)
    return float(spec.park_az_deg), float(park_el)


def _hold(x: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """Hold the first/last visible value over the padding before AOS and after LOS."""
    x = x.copy()
    x[:ia] = x[ia]
    x[ib + 1:] = x[ib]
    return x


def _unwrapped(spec: RotatorSpec, bearing_deg: np.ndarray, ia: int,
               ib: int) -> list[np.ndarray]:
    """Continuous mechanical azimuth over the visible part (held outside it).

    A step of nearly 180 deg between two samples (a pass through the zenith) has no
    "shorter way"; both ways round are returned as separate variants so the span fit decides.
    """
    m = np.asarray(spec.mech_of(bearing_deg), dtype=float)
    d = np.mod(np.diff(m[ia:ib + 1]) + 180.0, 360.0) - 180.0
    variants = [d]
    if len(d):
        # The fast swing near culmination: the contiguous run of large steps around the
        # largest one. If it turns more than 90 deg, also try going the other way round.
        big = int(np.argmax(np.abs(d)))
        large = np.abs(d) > 0.25 * abs(d[big])
        lo = big - int(np.argmin(large[big::-1])) + 1 if not large[:big + 1].all() else 0
        hi = big + int(np.argmin(large[big:])) if not large[big:].all() else len(d)
        swing = float(np.sum(d[lo:hi]))
        if abs(swing) > 90.0 and (hi - lo) <= 0.25 * len(d):
            alt = d.copy()
            alt[lo:hi] *= (swing - math.copysign(360.0, swing)) / swing
            variants.append(alt)
    out = []
    for steps in variants:
        seg = m[ia] + np.concatenate(([0.0], np.cumsum(steps)))
        full = np.empty_like(m)
        full[ia:ib + 1] = seg
        out.append(_hold(full, ia, ib))
    return out


def _shifts(spec: RotatorSpec, m_vis: np.ndarray) -> tuple[list[int], bool]:
    """Shifts k (m + 360 k) that put the whole visible path inside [0, span]; else the best."""
    lo, hi = float(np.min(m_vis)), float(np.max(m_vis))
    span = spec.az_span_deg
    ks = [k for k in range(-3, 4) if lo + 360 * k >= -1e-6 and hi + 360 * k <= span + 1e-6]
    if ks:
        return ks, True
    excess = [(max(0.0, -(lo + 360 * k)) + max(0.0, hi + 360 * k - span), k)
              for k in range(-3, 4)]
    return [min(excess)[1]], False


# Candidate evaluation ------------------------------------------------------------------------


@dataclass
class _Ctx:
    track: SkyTrack
    spec: RotatorSpec
    station: Station
    t: np.ndarray
    dt: np.ndarray
    visible: np.ndarray
    ia: int
    ib: int
    lead_s: float
    threshold_deg: float
    current: tuple[float, float]
    mask_max_deg: float  # highest horizon anywhere (for swings)


@dataclass
class _Result:
    score: CandidateScore
    cmd_az: np.ndarray
    cmd_el: np.ndarray
    ant_az: np.ndarray
    ant_el: np.ndarray
    error: np.ndarray


def _commanded(ctx: _Ctx, m: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lead, quantise, clamp to limits and lift to the mask: the values actually sent."""
    spec, t, res = ctx.spec, ctx.t, ctx.spec.resolution_deg
    if ctx.lead_s:
        m = np.interp(t + ctx.lead_s, t, m)
        e = np.interp(t + ctx.lead_s, t, e)
    qa = np.clip(np.round(m / res) * res, 0.0, spec.az_span_deg)
    if not spec.has_elevation:
        return qa + 0.0, np.zeros_like(qa)
    qe = np.clip(np.round(e / res) * res, spec.el_min_deg, spec.el_max_deg)
    qe = raise_to_mask(spec, ctx.station, qa, qe)
    # A big azimuth jump is a swing through every bearing in between: lift the elevation
    # over the highest mask point for as long as the swing takes.
    jump = np.abs(np.diff(qa))
    if ctx.mask_max_deg > 0 and np.any(jump > 30.0):
        for i in np.flatnonzero(jump > 30.0):
            t_end = t[i + 1] + spec.start_delay_s + jump[i] / spec.az_rate_deg_s
            win = (t >= t[i]) & (t <= t_end)
            lift = math.ceil(ctx.mask_max_deg / res) * res
            qe[win] = np.where(qe[win] <= 90.0, np.maximum(qe[win], lift),
                               np.minimum(qe[win], 180.0 - lift))
    return qa + 0.0, np.clip(qe, spec.el_min_deg, spec.el_max_deg) + 0.0  # no -0.0


def _evaluate(ctx: _Ctx, mode: str, m: np.ndarray, e: np.ndarray, fits: bool,
              note: str) -> _Result:
    spec, t = ctx.spec, ctx.t
    qa, qe = _commanded(ctx, m, e)
    change = np.ones(len(t), dtype=bool)
    change[1:] = (qa[1:] != qa[:-1]) | (qe[1:] != qe[:-1])
    cmd_t = t[change]
    az_axis = AxisMotor(0.0, spec.az_span_deg, spec.az_rate_deg_s, spec.start_delay_s,
                        spec.resolution_deg, qa[0], t[0] - 1.0)
    ant_az, starts = drive_axis(az_axis, cmd_t, qa[change], t)
    if spec.has_elevation:
        el_axis = AxisMotor(spec.el_min_deg, spec.el_top_deg, spec.el_rate,
                            spec.start_delay_s, spec.resolution_deg, qe[0], t[0] - 1.0)
        ant_el, el_starts = drive_axis(el_axis, cmd_t, qe[change], t)
        starts += el_starts
    else:
        ant_el = np.zeros_like(ant_az)
    err = pointing_error_deg(spec, ant_az, ant_el, (ctx.track.az_deg, ctx.track.el_deg))
    vis = ctx.visible
    ev = err[vis]
    lost = float(np.sum(ctx.dt[vis & (err > ctx.threshold_deg)]))
    travel = float(np.sum(np.abs(np.diff(ant_az))) + np.sum(np.abs(np.diff(ant_el))))
    travel += float(abs(qa[0] - ctx.current[0]) + (abs(qe[0] - ctx.current[1])
                                                   if spec.has_elevation else 0.0))
    score = CandidateScore(mode, fits, lost, float(ev.max()), float(ev.mean()),
                           float(np.percentile(ev, 99)), travel, int(starts), note)
    return _Result(score, qa, qe, ant_az, ant_el, err)


def _best(results: list[_Result], res_deg: float) -> _Result:
    return min(results, key=lambda r: r.score.rank_key(res_deg))


# Candidate generators ------------------------------------------------------------------------


def _shifted_candidates(ctx: _Ctx, bearing: np.ndarray, el: np.ndarray,
                        flip: bool) -> list[_Result]:
    spec, ia, ib = ctx.spec, ctx.ia, ctx.ib
    e = _hold(el, ia, ib)
    out = []
    for i, m_raw in enumerate(_unwrapped(spec, bearing, ia, ib)):
        out += _shift_variants(ctx, m_raw, e, flip, OTHER_WAY if i else "")
    return out


OTHER_WAY = "turning the other way round at culmination, "


def _shift_variants(ctx: _Ctx, m_raw: np.ndarray, e: np.ndarray, flip: bool,
                    prefix: str = "") -> list[_Result]:
    spec, ia, ib = ctx.spec, ctx.ia, ctx.ib
    ks, fits = _shifts(spec, m_raw[ia:ib + 1])
    out = []
    for k in ks:
        m = m_raw + 360.0 * k
        m_vis = m[ia:ib + 1]
        if flip:
            mode = "flip"
        else:
            mode = "overlap" if fits and m_vis.max() > 360.0 + 1e-6 else "normal"
        note = (f"{prefix}mech az {m_vis.min():.0f}..{m_vis.max():.0f}"
                + ("" if fits else f", clamped at the stops (needs "
                   f"{m_vis.max() - m_vis.min():.0f} deg from mech {m_vis.min():.0f})"))
        if flip and spec.el_top_deg < 180.0 - 1e-9:
            clipped = float(np.max(e[ia:ib + 1]) - spec.el_max_deg)
            if clipped > 0:
                note += f", el clamped at {spec.el_max_deg:g} (up to {clipped:.1f} deg short)"
        out.append(_evaluate(ctx, mode, m, e, fits, note))
    return out


def _keyhole_candidate(ctx: _Ctx) -> _Result | None:
    spec, ia, ib, track = ctx.spec, ctx.ia, ctx.ib, ctx.track
    u = azel_to_enu(track.az_deg, track.el_deg)
    ic = ia + int(np.argmax(track.el_deg[ia:ib + 1]))
    j0, j1 = max(ia, ic - 3), min(ib, ic + 3)
    if j1 == j0:
        return None
    motion = u[j1] - u[j0]
    if math.hypot(motion[0], motion[1]) < 1e-12:
        return None
    az_k = math.degrees(math.atan2(motion[0], motion[1])) + 180.0  # the AOS side
    h = np.array([math.sin(math.radians(az_k)), math.cos(math.radians(az_k)), 0.0])
    c = np.array([h[1], -h[0], 0.0])
    ux, uy, uz = u @ h, u @ c, u[:, 2]
    delta_exact = np.degrees(np.arctan2(uy * np.sign(ux + 1e-15), np.abs(ux)))
    results = []
    for cap in KEYHOLE_CAPS_DEG:
        delta = np.clip(delta_exact, -cap, cap)
        dr = np.radians(delta)
        el = np.degrees(np.arctan2(uz, ux * np.cos(dr) + uy * np.sin(dr)))
        el = np.clip(el, 0.0, 180.0)
        bearing = np.mod(az_k + delta, 360.0)
        for m_raw in _unwrapped(spec, bearing, ia, ib):
            ks, fits = _shifts(spec, m_raw[ia:ib + 1])
            for k in ks:
                note = (f"az held within {cap:g} deg of the along-track bearing "
                        f"{np.mod(az_k, 360.0):.0f}, el sweeps 0-180")
                results.append(_evaluate(ctx, "keyhole", m_raw + 360.0 * k,
                                         _hold(el, ia, ib), fits, note))
    return _best(results, spec.resolution_deg) if results else None


def _unwind_candidate(ctx: _Ctx, bearing: np.ndarray, el: np.ndarray,
                      flip: bool) -> _Result | None:
    spec, ia, ib, t = ctx.spec, ctx.ia, ctx.ib, ctx.t
    m_raw = _unwrapped(spec, bearing, ia, ib)[0]
    e = _hold(el, ia, ib)
    span = spec.az_span_deg

    def fit(v: float) -> list[int]:
        return [k for k in range(-3, 4) if -1e-6 <= v + 360 * k <= span + 1e-6]

    results = []
    for k1 in fit(m_raw[ia]):
        for k2 in fit(m_raw[ib]):
            if k1 == k2:
                continue
            a = m_raw + 360.0 * k1
            b = m_raw + 360.0 * k2
            inside_a = (a >= -1e-6) & (a <= span + 1e-6)
            inside_b = (b >= -1e-6) & (b <= span + 1e-6)
            grid = list(np.linspace(t[ia], t[ib], 9)[1:-1])
            out_a = np.flatnonzero(~inside_a[ia:ib + 1])
            in_b = np.flatnonzero(inside_b[ia:ib + 1])
            if len(out_a):
                grid.append(t[ia + out_a[0]])
            if len(in_b):
                grid.append(t[ia + in_b[0]])
            for t_sw in grid:
                m = np.where(t < t_sw, a, b)
                el_sw = float(np.interp(t_sw, t, ctx.track.el_deg))
                note = (f"{'flipped, ' if flip else ''}swing of {abs(k2 - k1) * 360} deg at "
                        f"{_hms(t_sw)} UTC (target el {el_sw:.0f})")
                results.append(_evaluate(ctx, "unwind", m, e, False, note))
    return _best(results, spec.resolution_deg) if results else None


def rate_limited_within(t_s: np.ndarray, target_deg: np.ndarray, half_width_deg: np.ndarray,
                        rate_deg_s: float) -> np.ndarray | None:
    """A path that turns at most ``rate_deg_s`` and stays within ``half_width_deg`` of
    ``target_deg`` at every sample, as close to the target as that allows; None when no such
    path exists.

    The positions reachable at each sample under the constraints before it and after it form
    an interval (a forward and a backward sweep of the tube); walking forward, each step goes
    to the point of that interval, within a step's travel, nearest the target. Where the
    target turns too fast, the path therefore starts turning early, as far ahead as needed.
    """
    n = len(t_s)
    if n == 0:
        return np.zeros(0)
    lo = (target_deg - half_width_deg).tolist()
    hi = (target_deg + half_width_deg).tolist()
    step = (rate_deg_s * np.diff(t_s)).tolist()
    for i in range(1, n):
        lo[i] = max(lo[i], lo[i - 1] - step[i - 1])
        hi[i] = min(hi[i], hi[i - 1] + step[i - 1])
    for i in range(n - 2, -1, -1):
        lo[i] = max(lo[i], lo[i + 1] - step[i])
        hi[i] = min(hi[i], hi[i + 1] + step[i])
    if any(a > b + 1e-9 for a, b in zip(lo, hi, strict=True)):
        return None
    want = target_deg.tolist()
    path = [min(max(want[0], lo[0]), hi[0])]
    for i in range(1, n):
        prev = path[-1]
        path.append(min(max(want[i], lo[i], prev - step[i - 1]), hi[i], prev + step[i - 1]))
    return np.array(path)


def _ahead_candidate(ctx: _Ctx, can_flip: bool) -> _Result | None:
    """The best ``ahead`` path (module doc): the azimuth within a band of the target's at a
    share of the rotator's rate, on each side, turn and way round that fits the span."""
    spec, ia, ib = ctx.spec, ctx.ia, ctx.ib
    results = []
    for flip in ((False, True) if can_flip else (False,)):
        bearing = np.mod(ctx.track.az_deg + (180.0 if flip else 0.0), 360.0)
        e = _hold(180.0 - ctx.track.el_deg if flip else ctx.track.el_deg, ia, ib)
        for m_raw in _unwrapped(spec, bearing, ia, ib):
            for band in AHEAD_BANDS_DEG:
                # The band's reach in azimuth around the target (a heuristic: the path is
                # scored by its real great-circle error like every candidate).
                half_width = az_extent_deg(band, e)
                for share in AHEAD_RATE_SHARES:
                    path = rate_limited_within(ctx.t, m_raw, half_width,
                                               share * spec.az_rate_deg_s)
                    if path is None:
                        continue
                    # The path leaves the target's azimuth by up to the band: it decides
                    # the turns that fit.
                    ks, fits = _shifts(spec, path[ia:ib + 1])
                    for k in ks:
                        note = (f"{'flipped, ' if flip else ''}azimuth within {band:g} deg "
                                f"of the target at {100 * share:.0f} % of the rotator's rate")
                        results.append(_evaluate(ctx, "ahead", path + 360.0 * k, e, fits,
                                                 note))
    return _best(results, spec.resolution_deg) if results else None


def _hms(t_s: float) -> str:
    return datetime.fromtimestamp(float(t_s), timezone.utc).strftime("%H:%M:%S")


# Pre-position and park -----------------------------------------------------------------------


def safe_moves(spec: RotatorSpec, station: Station, start: tuple[float, float],
                end: tuple[float, float], t0_s: float) -> tuple[list[Move], float]:
    """Mask-safe moves from ``start`` to ``end`` (mechanical az, el) beginning at ``t0_s``.

    Elevation first goes to a height that clears the mask over every bearing the azimuth
    sweeps, then azimuth moves, then elevation settles. Returns the moves and the duration.
    """
    m0, e0 = start
    m1, e1 = end
    if not spec.has_elevation:
        dur = slew_s(spec, m0, None, m1, None)
        return ([Move(t0_s, m1, 0.0)] if abs(m1 - m0) > 1e-9 else []), dur
    res = spec.resolution_deg
    swept = np.linspace(min(m0, m1), max(m0, m1), max(2, int(abs(m1 - m0)) + 2))
    hz = float(np.max(station.horizon_at(spec.bearing_of(swept))))
    hz = math.ceil(hz / res - 1e-9) * res
    moves: list[Move] = []
    t = t0_s
    if abs(m1 - m0) > 1e-9:
        e_mid = 90.0 if e0 > 90.0 else max(e0, hz)
        e_mid = min(max(e_mid, spec.el_min_deg), spec.el_top_deg)
        if abs(e_mid - e0) > 1e-9:
            moves.append(Move(t, m0, e_mid))
            t += slew_s(spec, m0, e0, m0, e_mid)
        moves.append(Move(t, m1, e_mid))
        t += slew_s(spec, m0, None, m1, None)
        e0 = e_mid
    if abs(e1 - e0) > 1e-9:
        moves.append(Move(t, m1, e1))
        t += slew_s(spec, m1, e0, m1, e1)
    return moves, t - t0_s


# Planning ------------------------------------------------------------------------------------


def _context(track: SkyTrack, spec: RotatorSpec, station: Station,
             current: tuple[float, float] | None, threshold_deg: float,
             lead_s: float | None) -> _Ctx:
    if len(track) < 2:
        raise LimitError(f"{track.name or 'target'}: the track needs at least two samples")
    t = np.asarray(track.t_s, dtype=float)
    horizon = np.asarray(station.horizon_at(track.az_deg))
    visible = track.el_deg >= horizon
    if not visible.any():
        raise LimitError(f"{track.name or 'target'} never rises above the horizon mask of "
                         f"station {station.name!r} in this track; pick another pass")
    idx = np.flatnonzero(visible)
    ia, ib = int(idx[0]), int(idx[-1])
    dt = np.diff(t)
    weights = np.concatenate((dt, dt[-1:]))
    step_s = float(np.median(dt))
    if lead_s is None:
        # A command waits start_delay_s, then the move; aiming half a step ahead centres the
        # target between commands.
        lead_s = spec.start_delay_s + 0.5 * step_s
    if current is None:
        current = (spec.park_az_deg, spec.park_el_deg if spec.has_elevation else 0.0)
    (az_lo, az_hi), el_lim = spec.axis_limits()
    if not az_lo <= current[0] <= az_hi or (
            el_lim is not None and not el_lim[0] <= current[1] <= el_lim[1]):
        raise LimitError(f"current antenna position (az {current[0]:g}, el {current[1]:g}) is "
                         f"outside the limits of rotator {spec.name!r} (mechanical az "
                         f"{az_lo:g}-{az_hi:g}" + (f", el {el_lim[0]:g}-{el_lim[1]:g})"
                                                   if el_lim else ")")
                         + "; give the position in mechanical degrees within them")
    mask_max = float(np.max(station.horizon_at(np.arange(0.0, 360.0, 1.0))))
    return _Ctx(track, spec, station, t, weights, visible, ia, ib, float(lead_s),
                float(threshold_deg), (float(current[0]), float(current[1])), mask_max)


def _assemble(ctx: _Ctx, chosen: _Result, results: list[_Result], reason: str,
              park: bool) -> MountPlan:
    spec, station, t = ctx.spec, ctx.station, ctx.t
    start = (float(chosen.cmd_az[0]), float(chosen.cmd_el[0]))
    moves, dur = safe_moves(spec, station, ctx.current, start, 0.0)
    arrive_by = t[ctx.ia] - ctx.lead_s - PREPOSITION_MARGIN_S
    t_pre = min(arrive_by, t[0]) - dur
    pre_moves = tuple(Move(m.t_s + t_pre, m.az_deg, m.el_deg) for m in moves)
    park_moves: tuple[Move, ...] = ()
    if park:
        end = (float(chosen.cmd_az[-1]), float(chosen.cmd_el[-1]))
        pm, _ = safe_moves(spec, station, end, park_position(spec, station),
                            t[ctx.ib] + ctx.lead_s + PREPOSITION_MARGIN_S)
        park_moves = tuple(pm)
    ordered = sorted(results, key=lambda r: r.score.rank_key(spec.resolution_deg))
    ordered.remove(chosen)
    ordered.insert(0, chosen)
    s = chosen.score
    return MountPlan(
        track=ctx.track, spec=spec, mode=s.mode, reason=reason, t_s=t,
        cmd_az_deg=chosen.cmd_az, cmd_el_deg=chosen.cmd_el, ant_az_deg=chosen.ant_az,
        ant_el_deg=chosen.ant_el, error_deg=chosen.error, visible=ctx.visible,
        candidates=tuple(r.score for r in ordered), preposition_t_s=float(t_pre),
        preposition=start, preposition_moves=pre_moves, park_moves=park_moves,
        max_error_deg=s.max_error_deg, mean_error_deg=s.mean_error_deg,
        p99_error_deg=s.p99_error_deg, lost_track_s=s.lost_track_s, travel_deg=s.travel_deg,
        motor_starts=s.motor_starts, threshold_deg=ctx.threshold_deg, lead_s=ctx.lead_s,
        meta={"current": ctx.current})


def plan_pass(track: SkyTrack, spec: RotatorSpec, station: Station,
              current: tuple[float, float] | None = None, *,
              threshold_deg: float = LOST_THRESHOLD_DEG, lead_s: float | None = None,
              park: bool = True) -> MountPlan:
    """Choose the mount path for one pass (see the module docstring).

    ``current`` is the antenna's (mechanical az, el) now; ``None`` means parked.
    ``threshold_deg`` is the pointing error above which a visible second counts as lost
    (half the beamwidth). ``lead_s`` is how far ahead commands aim (default: the motor's
    start delay plus half a track step).
    """
    ctx = _context(track, spec, station, current, threshold_deg, lead_s)
    az, el = track.az_deg, track.el_deg
    res_deg = spec.resolution_deg
    results = _shifted_candidates(ctx, az, el, flip=False)
    can_flip = spec.has_elevation and spec.el_top_deg > 90.0
    if can_flip:
        results += _shifted_candidates(ctx, np.mod(az + 180.0, 360.0), 180.0 - el, flip=True)
    max_el = float(np.max(el[ctx.ia:ctx.ib + 1]))
    if can_flip and max_el >= KEYHOLE_MIN_EL_DEG:
        kh = _keyhole_candidate(ctx)
        if kh is not None:
            results.append(kh)
    if min(r.score.lost_track_s for r in results if r.score.mode != "keyhole") > 0:
        for flip in ((False, True) if can_flip else (False,)):
            bearing = np.mod(az + 180.0, 360.0) if flip else az
            uw = _unwind_candidate(ctx, bearing, 180.0 - el if flip else el, flip)
            if uw is not None:
                results.append(uw)
    # keep one result per mode+shift: the generators already pruned variants
    chosen = _best(results, res_deg)
    if chosen.score.lost_track_s > 0:
        ahead = _ahead_candidate(ctx, can_flip)
        if ahead is not None:
            results.append(ahead)
            chosen = _best(results, res_deg)
    reason = _reason(ctx, chosen, results)
    return _assemble(ctx, chosen, results, reason, park)


def gpredict_plan(track: SkyTrack, spec: RotatorSpec, station: Station,
                  current: tuple[float, float] | None = None, *,
                  threshold_deg: float = LOST_THRESHOLD_DEG, lead_s: float | None = None,
                  park: bool = False) -> MountPlan:
    """The Gpredict rule (its gtk-rot-ctrl.c), as a baseline for the benchmark.

    The pass is "flipped" when its azimuth trace, wrapped into the 360 deg window that starts
    at the stop, jumps by more than 180 deg; a flipped pass uses (az + 180, 180 - el) only if
    el max is 180 (exactly as ``maxel >= 180``). No overlap is used: azimuth stays in the
    0-360 window and targets are clamped to the limits. Commands, lead and motor model are
    the same as the planner's, so only the path policy differs.
    """
    ctx = _context(track, spec, station, current, threshold_deg, lead_s)
    ia, ib = ctx.ia, ctx.ib
    m = np.asarray(spec.mech_of(track.az_deg))
    flipped = bool(np.any(np.abs(np.diff(m[ia:ib + 1])) > 180.0))
    el = track.el_deg
    if flipped and spec.has_elevation and spec.el_top_deg >= 180.0:
        m = np.asarray(spec.mech_of(np.mod(track.az_deg + 180.0, 360.0)))
        el = 180.0 - el
        mode = "flip"
        note = "gpredict: flipped pass, el max 180"
    else:
        mode = "normal"
        note = "gpredict: " + ("crosses the stop, no flip possible" if flipped
                               else "inside the 0-360 window")
    r = _evaluate(ctx, mode, _hold(m, ia, ib), _hold(el, ia, ib), not flipped or
                  mode == "flip", note)
    return _assemble(ctx, r, [r], note, park)


# Explanations -------------------------------------------------------------------------------


def _reason(ctx: _Ctx, chosen: _Result, results: list[_Result]) -> str:
    spec, s = ctx.spec, chosen.score
    stop = {0.0: "north", 180.0: "south"}.get(spec.stop_bearing_deg,
                                              f"{spec.stop_bearing_deg:g} deg")
    base = {
        "normal": f"the pass stays inside the azimuth span without crossing the {stop} stop",
        "overlap": (f"the pass crosses the {stop} stop; the {spec.az_span_deg:g} deg span's "
                    f"overlap keeps the antenna on it without an unwind"),
        "flip": (f"the pass would cross the {stop} stop, so the antenna points over the top "
                 f"(az + 180, 180 - el) for the whole pass"),
        "keyhole": ("the near-overhead pass needs an azimuth rate the rotator lacks, so "
                    "azimuth stays near the along-track bearing while elevation sweeps "
                    "through the zenith"),
        "unwind": "no path fits the azimuth span, so the antenna unwinds once",
        "ahead": ("the near-overhead pass turns faster in azimuth than the rotator can, so "
                  "the azimuth starts its turn early and keeps ahead of the target"),
    }[s.mode]
    detail = f" ({s.note})" if s.note else ""
    others = sorted((r for r in results if r is not chosen),
                    key=lambda r: r.score.rank_key(spec.resolution_deg))
    why = ""
    if others:
        o = others[0].score
        if o.lost_track_s > s.lost_track_s + 1e-9:
            why = f"; the next best ({o.mode}) loses {o.lost_track_s:.0f} s vs " \
                  f"{s.lost_track_s:.0f} s"
        elif round(o.max_error_deg / spec.resolution_deg) > round(
                s.max_error_deg / spec.resolution_deg):
            why = f"; the next best ({o.mode}) has max error {o.max_error_deg:.1f} deg vs " \
                  f"{s.max_error_deg:.1f} deg"
        elif o.travel_deg > s.travel_deg:
            why = f"; it travels {s.travel_deg:.0f} deg vs {o.travel_deg:.0f} deg ({o.mode})"
        elif o.motor_starts > s.motor_starts:
            why = f"; fewer motor starts than {o.mode} ({s.motor_starts} vs {o.motor_starts})"
        else:
            why = f"; {o.mode} scores the same, the simpler mode is kept"
    return f"{s.mode.capitalize()}: {base}{detail}{why}."


def error_cause(track: SkyTrack, spec: RotatorSpec, mode: str, t_s: np.ndarray,
                error_deg: np.ndarray, step_s: float | None = None,
                threshold_deg: float = LOST_THRESHOLD_DEG) -> str:
    """One line saying why a predicted or measured pointing error is large ("" when its
    maximum stays within ``threshold_deg``): the mid-pass unwind, an azimuth rate the rotator
    lacks (worst without an elevation axis to point over the top), or steps ``step_s`` apart
    that the target outruns. ``error_deg`` at ``t_s`` is judged as the planner judges it
    (azimuth only for an azimuth-only rotator)."""
    err = np.asarray(error_deg, dtype=float)
    ok = np.isfinite(err)
    if not ok.any() or float(np.max(err[ok])) <= threshold_deg:
        return ""
    t = np.asarray(t_s, dtype=float)[ok]
    i = int(np.argmax(err[ok]))
    t_worst = float(t[i])
    worst = float(err[ok][i])
    what = "azimuth error" if not spec.has_elevation else "error"
    when = datetime.fromtimestamp(t_worst, timezone.utc).strftime("%H:%M:%S UTC")
    if mode == "unwind":
        return (f"max {what} {worst:.0f} deg at {when}: no path fits the azimuth span, so "
                f"the antenna unwinds once (a 360 deg swing) while the target moves on")
    el_here = float(np.interp(t_worst, track.t_s, track.el_deg))
    where = f"max {what} {worst:.0f} deg at {when} (target el {el_here:.0f})"
    if step_s is not None:
        a0 = track.direction_at(t_worst - step_s / 2.0)
        a1 = track.direction_at(t_worst + step_s / 2.0)
        moved = float(angle_between_deg(azel_to_enu(*a0), azel_to_enu(*a1)))
        az_moved = abs((float(a1[0]) - float(a0[0]) + 180.0) % 360.0 - 180.0)
        if max(moved, az_moved) > threshold_deg:
            which = "target" if moved >= az_moved else "target's azimuth"
            return (f"{where}: the interval is too long for this pass; the {which} moves "
                    f"{max(moved, az_moved):.0f} deg between two steps {step_s:g} s apart")
    # The target's azimuth rate around the worst moment (over 10 s: a pass's peak rate).
    win = (track.t_s >= t_worst - 10.0) & (track.t_s <= t_worst + 10.0)
    az_rate = 0.0
    if win.sum() >= 2:
        az = np.degrees(np.unwrap(np.radians(track.az_deg[win])))
        az_rate = float(np.max(np.abs(np.gradient(az, track.t_s[win]))))
    if az_rate > spec.az_rate_deg_s:
        axis = ("; an azimuth-only rotator has no elevation axis to follow it over the top"
                if not spec.has_elevation else "")
        return (f"{where}: the target's azimuth turns {az_rate:.0f} deg/s there, faster "
                f"than the rotator's {spec.az_rate_deg_s:g} deg/s{axis}")
    return f"{where}: the rotator cannot keep up with the target there"
