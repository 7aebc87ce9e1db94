"""A clairvoyant lower bound on motor starts for a pass kept within a great-circle deadband.

:func:`start_lower_bound` answers: whatever commands are sent (at any times, knowing the
whole pass), how many motor starts must a rotator of THE motor model (:class:`tracker.mount.
AxisMotor`: per axis a fixed rate, a start delay, integer targets, a command while moving
retargets, a start counted as :func:`tracker.mount.drive_axis` counts it) make from rest at
park so that the great-circle error (:func:`tracker.geometry.pointing_error_deg`) is at most
``band_deg`` at every sample time? The answer is a number no schedule can beat, found by a
dynamic programme over a *relaxed* model; None means even the relaxed model cannot keep the
band, so no schedule can.

Why it is a lower bound (each relaxation only adds trajectories or lowers their count):

1. *Starts >= onsets.* In the motor model an axis is at rest, waiting out a start delay, or
   turning at exactly its rate. Call an *onset* the beginning of a maximal stretch of turning
   in one direction. A turning motor stops only on arriving or on a reversal, and a retarget
   in its direction neither starts it nor begins a new stretch, so every onset follows a
   start of its own (from rest, or a reversal) and a command sequence's starts are at least
   its trajectory's onsets (a start cut short in its delay makes none). The start delay
   becomes a stretch at rest; integer targets, command times and the pre-AOS timing are
   forgotten: the relaxed trajectories are all piecewise-linear paths with slopes in
   {-rate, 0, +rate} per axis, and the real ones are among them.
2. *Constraints at sample times only* (every ``stride``-th of ``t_s``; ``stride`` > 1 drops
   constraints).
3. *Counting onsets between samples exactly.* Between two samples Δ apart an axis with the
   slope p just before the first sample and q just before the second, moving d, needs at
   least (L = rate·Δ, |d| <= L always): p = q = +: 0 if d = L (it turned the whole time),
   1 if 0 <= d < L, 2 if d < 0; p in {0, -}, q = +: 1, except p = 0 with d < 0: 2;
   q = 0: 0 if p = 0 and d = 0, or p = + and d >= 0 (or - and d <= 0), else 1; q = -:
   mirrored. (An onset is charged to the interval it starts in.) So a slow target is not
   followed for free: turning continues only at the full rate.
4. *Cells.* Positions are binned into cells of width h = L/m (m integer), half-open, on a
   grid from the axis's lower limit. A transition between cells costs the least of the
   costs above over all pairs of points in the two cells: with L = m·h a whole interval of
   turning moves exactly m cells, so chains of turning are not sped up or slowed down by
   the binning; "d >= 0" is possible for a cell shift s >= 0, "d = 0" for s = 0, and so on.
   A cell is feasible at a sample when *any* point of it is within the band: its centre
   within band + ρ, ρ = hypot(h_el/2, h_az/2·max|cos el| over the cell) (a straight line in
   (az, el) from the centre to any point of the cell is at most ρ long on the sky, and the
   great-circle distance obeys the triangle inequality). So every relaxed trajectory maps to
   a cell path that the programme allows, at no higher cost.
5. *Before AOS* an axis that is not at rest on park at AOS made at least one onset; nothing
   else (reach, timing) is asked of the pre-position.
6. *The mount branch.* At each sample only a box around the target on the planner's path's
   side of the zenith and nearest its mechanical azimuth is searched, holding every cell
   within the band on that branch: mechanical az within w = asin(sin D'/cos el) of the
   target's, el within D' (D' = band + a cell diagonal). Where the target is within D' of
   the zenith (the only place a mount can pass from one side of it to the other within the
   band) the box is one whole turn around the path's azimuth and every el on either side
   within D', so a schedule going over the top is kept. The bound holds for every schedule
   that follows the planner's branch (the same overlap turn and flip choice), which the live
   loop and :func:`tracker.schedule.plan_schedule` do.
7. *Every branch* (:func:`start_lower_bound_any_branch`). Away from the zenith the points
   within reach of the target form disjoint boxes, one per side (upright, or over the top
   at az + 180, el 180 - el) and whole turn. A schedule cannot go from one box to another
   between two such samples: another turn is at least 180 deg of azimuth away, more than an
   interval's travel (checked); the other side is 180 - e1 - e2 - 2 r deg of elevation away (e1, e2
   the target's elevations, r the reach), so crossing within one interval's elevation travel
   L puts the target within r + L/2 of the zenith at one of the two samples. The zenith
   region is therefore widened to r + L/2 and searched over every mechanical azimuth and both
   sides; taken from its first sample to its last (which holds the culmination), it is one
   stretch, the only one where a schedule may change side or turn. So every schedule keeps
   one side and turn before the culmination and one after it: the paths of
   :func:`branch_paths`, each bounded as in item 6 with that region. The least of those
   bounds is at most the starts of any schedule that keeps the band; None on every branch
   means no schedule can.

The programme's value is the least cost over its paths, so it is at most the onsets, hence
the starts, of every schedule that keeps the band. The transition min-plus product is
separable per axis, and each axis's costs depend on the cell shift only through ranges
[-m, 0], [0, m], [-m, m] and the exact shift ±m, so one step is a few running minima
(O(states): numpy, or the same arithmetic as compiled loops, :func:`_bound_loop`).

What the relaxations give away, so a real schedule needs more: holds at whole degrees only
(on short synthetic passes, allowing rest only on whole-degree cells, which also forbids the
rare reversal pause and so overstates the gain, raised the bound by 5-9 %), the start delay,
the loop's 0.5 s command cycle, and the cells' slack ρ (under 0.15 deg with the default
``cell_deg``; halving the cells raised the bound by 0-4 %).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tracker import compiled
from tracker.geometry import az_extent_deg
from tracker.mount import RotatorSpec

# The state of one axis just before a sample: at rest, turning up, turning down.
_REST, _UP, _DOWN = 0, 1, 2
# A cell counts as feasible with this much slack beyond band + ρ (rounding of the angle).
_SLACK_DEG = 1e-6


def _cut(x: np.ndarray, axis: int, a: int, b: int) -> np.ndarray:
    idx: list[Any] = [slice(None)] * x.ndim
    idx[axis] = slice(a, b)
    return x[tuple(idx)]


def _window_min(x: np.ndarray, axis: int, width: int) -> np.ndarray:
    """``out[o] = min(x[o : o + width])`` along ``axis`` (length n - width + 1), by doubling."""
    r, w = x, 1
    while 2 * w <= width:
        n = r.shape[axis]
        r = np.minimum(_cut(r, axis, 0, n - w), _cut(r, axis, w, n))
        w *= 2
    if w < width:
        n, k = r.shape[axis], width - w
        r = np.minimum(_cut(r, axis, 0, n - k), _cut(r, axis, k, n))
    return r


def _axis_step(v: np.ndarray, m: int) -> np.ndarray:
    """One sample interval for one axis (module doc, item 3): ``v`` is (3 modes, K, n, J) over
    source cells; the result is (3, K, n - 2m, J) over the cells m inside either end."""
    v0, vp, vn = v[_REST], v[_UP], v[_DOWN]
    n_out = v.shape[2] - 2 * m
    runs = _window_min(v, 2, m + 1)
    lo, hi = runs[:, :, :n_out], runs[:, :, m:m + n_out]     # cells [j-m, j] and [j, j+m]
    full_up, full_down = np.minimum(lo[_UP], hi[_UP]), np.minimum(lo[_DOWN], hi[_DOWN])
    from_below = np.minimum(lo[_REST], lo[_UP])               # at rest or turning up, below
    from_above = np.minimum(hi[_REST], hi[_DOWN])
    anything = np.minimum(np.minimum(from_below, from_above), np.minimum(full_up, full_down))
    out = np.empty((3, *lo.shape[1:]), dtype=v.dtype)
    # Resting: stayed, or stopped after turning toward the cell (0), or anything else (1).
    np.minimum(np.minimum(v0[:, m:m + n_out], lo[_UP]), np.minimum(hi[_DOWN], anything + 1),
               out=out[_REST])
    # Turning up: went on turning (exact shift m, 0), a new onset from rest / below /
    # after turning down (1), a dip first (2).
    np.minimum(np.minimum(vp[:, :n_out], np.minimum(from_below, full_down) + 1), anything + 2,
               out=out[_UP])
    np.minimum(np.minimum(vn[:, 2 * m:2 * m + n_out], np.minimum(from_above, full_up) + 1),
               anything + 2, out=out[_DOWN])
    return out


class _Grid:
    """One axis's cells: width ``h`` from ``lo_deg``, ``n`` cells reaching ``hi_deg``."""

    def __init__(self, lo_deg: float, hi_deg: float, step_deg: float, m: int):
        self.lo, self.m, self.h = lo_deg, m, step_deg / m
        self.n = math.floor((hi_deg - lo_deg) / self.h) + 1

    def index(self, x_deg: np.ndarray) -> np.ndarray:
        return np.clip(np.floor((x_deg - self.lo) / self.h), 0, self.n - 1).astype(int)

    def centres(self, a: int, b: int) -> np.ndarray:
        return self.lo + (np.arange(a, b) + 0.5) * self.h


def _near_zenith(target_el: np.ndarray, reach_deg: float) -> np.ndarray:
    """Samples where the target is within ``reach_deg`` of the zenith."""
    c = np.cos(np.radians(np.clip(target_el, -90.0, 90.0)))
    return c <= math.sin(math.radians(min(reach_deg, 90.0)))


def _boxes(spec: RotatorSpec, grid_az: _Grid, grid_el: _Grid, path_az: np.ndarray,
           path_el: np.ndarray, bearing: np.ndarray, target_el: np.ndarray,
           reach_deg: float, zenith: np.ndarray | None = None) -> np.ndarray:
    """Per sample the cell box (az0, az1, el0, el1, half-open) holding every point of the
    path's branch within ``reach_deg`` of the target (module doc, item 6). ``zenith``: the
    samples to treat as near the zenith, where every mechanical azimuth is searched (module
    doc, item 7); by default those within reach, searched over one turn."""
    centre_az, centre_el = _branch_centre(spec, path_az, path_el, bearing, target_el)
    whole_span = zenith is not None
    if zenith is None:
        zenith = _near_zenith(target_el, reach_deg)
    w = np.where(zenith, 180.0, az_extent_deg(reach_deg, target_el)) + grid_az.h
    # Near the zenith both sides of it are within reach: one turn around the path's own az
    # (which moves smoothly where the path goes over the top), elevations on either side.
    centre_az = np.where(zenith, path_az, centre_az)
    el_r = reach_deg + grid_el.h
    el_lo = np.where(zenith, target_el, centre_el) - el_r
    el_hi = np.where(zenith, 180.0 - target_el, centre_el) + el_r
    az0, az1 = grid_az.index(centre_az - w), grid_az.index(centre_az + w) + 1
    if whole_span:
        az0, az1 = np.where(zenith, 0, az0), np.where(zenith, grid_az.n, az1)
    return np.stack([az0, az1, grid_el.index(el_lo), grid_el.index(el_hi) + 1], axis=1)


class _Sky:
    """Per global cell what the feasibility test needs (module doc, item 4): the unit vector's
    parts of each az cell centre (bearing) and el cell centre, and per el row the cosine of
    band + ρ, so a cell is feasible when its centre's dot product with the target reaches it."""

    def __init__(self, spec: RotatorSpec, grid_az: _Grid, grid_el: _Grid, band_deg: float):
        bearing = np.radians(np.asarray(spec.bearing_of(grid_az.centres(0, grid_az.n)),
                                        dtype=float))
        self.cos_b, self.sin_b = np.cos(bearing), np.sin(bearing)
        el = grid_el.centres(0, grid_el.n)
        half = 0.5 * grid_el.h
        self.cos_e, self.sin_e = np.cos(np.radians(el)), np.sin(np.radians(el))
        cos_max = np.maximum(np.abs(np.cos(np.radians(el - half))),
                             np.abs(np.cos(np.radians(el + half))))
        rho = np.hypot(half, 0.5 * grid_az.h * cos_max)
        self.min_dot = np.cos(np.radians(np.minimum(band_deg + rho + _SLACK_DEG, 180.0)))

    def feasible(self, box: np.ndarray, bearing_deg: float, el_deg: float) -> np.ndarray:
        """Cells of ``box`` with some point within the band of the target."""
        b, e = math.radians(bearing_deg), math.radians(el_deg)
        a0, a1, e0, e1 = (int(x) for x in box)
        along = self.cos_b[a0:a1] * math.cos(b) + self.sin_b[a0:a1] * math.sin(b)
        dot = (self.cos_e[e0:e1] * math.cos(e))[None, :] * along[:, None] \
            + (self.sin_e[e0:e1] * math.sin(e) - self.min_dot[e0:e1])[None, :]
        return dot >= 0.0


def _initial(grid_az: _Grid, grid_el: _Grid, box: tuple[int, int, int, int],
             park: tuple[float, float]) -> np.ndarray:
    """Onsets before AOS per state at AOS (item 5): 0 for an axis at rest on park's cell."""
    costs = []
    for grid, a, b, p in ((grid_az, box[0], box[1], park[0]),
                          (grid_el, box[2], box[3], park[1])):
        c = np.ones((3, b - a), dtype=np.float32)
        k = int(grid.index(np.array([p]))[0]) - a
        if 0 <= k < b - a:
            c[_REST, k] = 0.0
        costs.append(c)
    return (costs[0][:, None, :, None] + costs[1][None, :, None, :]).astype(np.float32)


def _trimmed(box: np.ndarray, ok: np.ndarray
             ) -> tuple[tuple[int, int, int, int] | None, np.ndarray]:
    """The box cut to the cells of it that are feasible (``ok``), and ``ok`` cut alike;
    None when none is."""
    rows, cols = np.flatnonzero(ok.any(axis=1)), np.flatnonzero(ok.any(axis=0))
    if len(rows) == 0:
        return None, ok
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    a0, e0 = int(box[0]), int(box[2])
    return (a0 + r0, a0 + r1, e0 + c0, e0 + c1), ok[r0:r1, c0:c1]


def _paste(src: np.ndarray, origin: tuple[int, int], v: np.ndarray, at: tuple[int, int]
           ) -> None:
    """Copy ``v`` (cells from global ``at``) into ``src`` (cells from global ``origin``)."""
    a0, e0 = max(origin[0], at[0]), max(origin[1], at[1])
    a1 = min(origin[0] + src.shape[2], at[0] + v.shape[2])
    e1 = min(origin[1] + src.shape[3], at[1] + v.shape[3])
    if a1 > a0 and e1 > e0:
        src[:, :, a0 - origin[0]:a1 - origin[0], e0 - origin[1]:e1 - origin[1]] = \
            v[:, :, a0 - at[0]:a1 - at[0], e0 - at[1]:e1 - at[1]]


def _branch_centre(spec: RotatorSpec, path_az_m_deg: np.ndarray, path_el_deg: np.ndarray,
                  bearing_deg: np.ndarray, el_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The target's mechanical az / el on a path's branch: the az nearest the path's, over the
    top where the path is (el > 90)."""
    over = np.asarray(path_el_deg) > 90.0
    looks = np.asarray(spec.bearing_of(path_az_m_deg)) + np.where(over, 180.0, 0.0)
    az = np.asarray(path_az_m_deg) + (np.mod(np.asarray(bearing_deg) - looks + 180.0, 360.0)
                                      - 180.0)
    return az, np.where(over, 180.0 - np.asarray(el_deg), np.asarray(el_deg))


def start_lower_bound(spec: RotatorSpec, t_s: np.ndarray, bearing_deg: np.ndarray,
                      el_deg: np.ndarray, path_az_m_deg: np.ndarray,
                      path_el_deg: np.ndarray, band_deg: float,
                      park: tuple[float, float] | None = None, cell_deg: float = 0.2,
                      stride: int = 1) -> int | None:
    """Fewest motor starts any schedule can make from rest on ``park`` (default the spec's) so
    that the great-circle error to the target (``bearing_deg``, ``el_deg`` at the uniformly
    spaced ``t_s``) stays within ``band_deg`` at every ``stride``-th sample, the mount staying
    on the branch of the mount path at ``path_az_m_deg`` / ``path_el_deg`` (mechanical; the
    planner's); None when no schedule can (module doc: the relaxations and why each
    keeps this a lower bound). Cells are about ``cell_deg`` wide (smaller: tighter, slower)."""
    return _least_starts(spec, t_s, bearing_deg, el_deg, path_az_m_deg, path_el_deg,
                         band_deg, park, cell_deg, stride, any_turn=False)


def start_lower_bound_any_branch(spec: RotatorSpec, t_s: np.ndarray, bearing_deg: np.ndarray,
                                 el_deg: np.ndarray, band_deg: float,
                                 park: tuple[float, float] | None = None,
                                 cell_deg: float = 0.2, stride: int = 1
                                 ) -> tuple[int, str] | None:
    """:func:`start_lower_bound` over every mount branch (module doc, item 7): the fewest
    starts of any schedule whatsoever that keeps the band, with the name of the branch that
    allows them; None when no schedule on any branch can keep it (the rotator cannot follow
    the target within ``band_deg``, whatever it is sent)."""
    el = np.asarray(el_deg, dtype=float)
    step = max(1, int(stride))
    dt_s = float(t_s[step] - t_s[0]) if len(t_s) > step else 1.0
    # At least the widened zenith reach of _least_starts (cells are at most 1.5 cell_deg):
    # where not even this comes near the zenith, no schedule can change side or turn.
    reach_deg = band_deg + 1.5 * math.sqrt(2.0) * cell_deg + 0.5 * spec.el_rate * dt_s + 0.01
    best: tuple[int, str] | None = None
    for name, path_az, path_el in branch_paths(spec, bearing_deg, el,
                                               bool(_near_zenith(el, reach_deg).any())):
        n = _least_starts(spec, t_s, bearing_deg, el, path_az, path_el, band_deg, park,
                          cell_deg, stride, any_turn=True)
        if n is not None and (best is None or n < best[0]):
            best = (n, name)
    return best


def branch_paths(spec: RotatorSpec, bearing_deg: np.ndarray, el_deg: np.ndarray,
                 may_cross: bool = True) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """One mount path per branch a schedule can be on (module doc, item 7): upright or over
    the top, on each turn that reaches the limits, before the culmination and after it
    (``(name, mechanical az, el)``). Without ``may_cross`` (the target stays far from the
    zenith) only branches that keep one side and turn throughout."""
    bearing = np.asarray(bearing_deg, dtype=float)
    el = np.asarray(el_deg, dtype=float)
    ic = int(np.argmax(el)) + 1
    sides = {over: _side(spec, bearing, el, over) for over in (False, True)}
    out = []
    for over_before in (False, True):
        m_b, e_b = sides[over_before]
        for over_after in (False, True):
            m_a, e_a = sides[over_after]
            for k_before in _turns(spec, m_b[:ic]):
                turns_after = _turns(spec, m_a[ic:]) if ic < len(el) else [k_before]
                for k_after in turns_after:
                    same = (over_after, k_after) == (over_before, k_before)
                    if not (same or (may_cross and ic < len(el))):
                        continue
                    az = np.concatenate([m_b[:ic] + 360.0 * k_before,
                                         m_a[ic:] + 360.0 * k_after])
                    name = (_branch_name(over_before, az) if same else
                            f"{_branch_name(over_before, az[:ic])} then "
                            f"{_branch_name(over_after, az[ic:])}")
                    out.append((name, az, np.concatenate([e_b[:ic], e_a[ic:]])))
    return out


def _branch_name(over: bool, az_m_deg: np.ndarray) -> str:
    """``upright, mech az 30..210``: the side and where on the span the target is kept."""
    a, b = round(float(az_m_deg[0])), round(float(az_m_deg[-1]))
    return f"{'over the top' if over else 'upright'}, mech az {a}" + (f"..{b}" if b != a else "")


def _side(spec: RotatorSpec, bearing_deg: np.ndarray, el_deg: np.ndarray, over: bool
          ) -> tuple[np.ndarray, np.ndarray]:
    """The target's continuous mechanical az (one unwrapping over the whole track) and el,
    upright or over the top."""
    look = np.mod(bearing_deg + (180.0 if over else 0.0), 360.0)
    m = np.degrees(np.unwrap(np.radians(np.asarray(spec.mech_of(look), dtype=float))))
    return m, (180.0 - el_deg if over else el_deg)


def _turns(spec: RotatorSpec, m_deg: np.ndarray) -> list[int]:
    """Whole turns k whose ``m_deg + 360 k`` comes within 180 deg of the azimuth limits: a
    branch's box reaches up to that far from the target's azimuth (an antenna at the stop
    can keep the band of a target just beyond it)."""
    (az_lo, az_hi), _el = spec.axis_limits()
    lo, hi = float(np.min(m_deg)), float(np.max(m_deg))
    return [k for k in range(-3, 4)
            if hi + 360.0 * k >= az_lo - 180.0 and lo + 360.0 * k <= az_hi + 180.0]


def _zenith_hull(target_el: np.ndarray, reach_deg: float) -> np.ndarray:
    """Every sample from the first to the last one within ``reach_deg`` of the zenith."""
    near = np.flatnonzero(_near_zenith(target_el, reach_deg))
    out = np.zeros(len(target_el), dtype=bool)
    if len(near):
        out[near[0]:near[-1] + 1] = True
    return out


def _least_starts(spec: RotatorSpec, t_s: np.ndarray, bearing_deg: np.ndarray,
                  el_deg: np.ndarray, path_az_m_deg: np.ndarray, path_el_deg: np.ndarray,
                  band_deg: float, park: tuple[float, float] | None, cell_deg: float,
                  stride: int, any_turn: bool) -> int | None:
    if not spec.has_elevation:
        raise ValueError("start_lower_bound needs an az/el rotator")
    idx = np.arange(0, len(t_s), max(1, int(stride)))
    if len(idx) == 0:
        return 0
    dt_s = float(t_s[idx[1]] - t_s[idx[0]]) if len(idx) > 1 else 1.0
    (az_lo, az_hi), el_lim = spec.axis_limits()
    assert el_lim is not None
    grids = []
    for rate, lo, hi in ((spec.az_rate_deg_s, az_lo, az_hi), (spec.el_rate, *el_lim)):
        step = rate * dt_s
        grids.append(_Grid(lo, hi, step, max(1, round(step / cell_deg))))
    ga, ge = grids
    if any_turn and spec.az_rate_deg_s * dt_s >= 180.0 - 2.0 * ga.h:
        # Item 7 needs another turn's box out of one interval's reach.
        raise ValueError(f"the bound over every branch needs samples less than "
                         f"{(180.0 - 2.0 * ga.h) / spec.az_rate_deg_s:.1f} s apart "
                         f"(a smaller stride)")
    reach = band_deg + math.hypot(ga.h, ge.h) + _SLACK_DEG
    target_el = np.asarray(el_deg, dtype=float)[idx]
    # Any branch: widened by half an interval's elevation travel, so a schedule changing
    # side between two samples is within the region at one of them (module doc, item 7).
    zenith = _zenith_hull(target_el, reach + 0.5 * ge.m * ge.h) if any_turn else None
    boxes = _boxes(spec, ga, ge, np.asarray(path_az_m_deg, dtype=float)[idx],
                   np.asarray(path_el_deg, dtype=float)[idx],
                   np.asarray(bearing_deg, dtype=float)[idx], target_el, reach, zenith)
    park = park if park is not None else (spec.park_az_deg, spec.park_el_deg)
    sky = _Sky(spec, ga, ge, band_deg)
    box, ok = _trimmed(boxes[0], sky.feasible(boxes[0], float(bearing_deg[idx[0]]),
                                              float(el_deg[idx[0]])))
    if box is None:
        return None
    v = np.where(ok[None, None], _initial(ga, ge, box, park), np.float32(np.inf))
    if not np.isfinite(v).any():
        return None
    if compiled.backend() == "numba":
        # The target's trigonometry as sky.feasible takes it (math, not numpy: the same bits).
        b = [math.radians(float(bearing_deg[i])) for i in idx]
        e = [math.radians(float(el_deg[i])) for i in idx]
        trig = np.array([[math.cos(x) for x in b], [math.sin(x) for x in b],
                         [math.cos(x) for x in e], [math.sin(x) for x in e]])
        least = _loops("_bound_loop")(boxes, sky.cos_b, sky.sin_b, sky.cos_e, sky.sin_e,
                                      sky.min_dot, trig, ga.m, ge.m, v, box[0], box[2])
        return None if least < 0 else least
    at = (box[0], box[2])
    for k in range(1, len(idx)):
        i = idx[k]
        box, ok = _trimmed(boxes[k], sky.feasible(boxes[k], float(bearing_deg[i]),
                                                  float(el_deg[i])))
        if box is None:
            return None
        src = np.full((3, 3, box[1] - box[0] + 2 * ga.m, box[3] - box[2] + 2 * ge.m),
                      np.inf, dtype=np.float32)
        _paste(src, (box[0] - ga.m, box[2] - ge.m), v, at)
        v = _axis_step(src, ga.m)
        v = _axis_step(v.transpose(1, 0, 3, 2), ge.m).transpose(1, 0, 3, 2)
        v = np.where(ok[None, None], v, np.float32(np.inf))
        at = (box[0], box[2])
        if not np.isfinite(v).any():
            return None
    return int(v.min())


def _bound_loop(boxes, cos_b, sin_b, cos_e, sin_e, min_dot, trig, m_az, m_el, v, at_az, at_el
                ):  # pragma: no cover - compiled by numba (its twin: _least_starts's loop)
    """The programme from sample 1 on, from ``v`` (sample 0's costs, its box from ``at_az``,
    ``at_el``): the least cost at the last sample, or -1 where some sample has no finite
    cost. ``trig``: per sample cos and sin of the target's bearing, then of its elevation."""
    inf = np.float32(np.inf)
    for k in range(1, len(boxes)):
        ok, r0, r1, c0, c1 = _feasible_cells(boxes[k], cos_b, sin_b, cos_e, sin_e, min_dot,
                                             trig[:, k])
        if r1 < 0:
            return -1
        n_az, n_el = r1 + 1 - r0, c1 + 1 - c0
        a0, e0 = boxes[k, 0] + r0, boxes[k, 2] + c0
        src = np.full((3, 3, n_az + 2 * m_az, n_el + 2 * m_el), inf, np.float32)
        _paste_into(src, v, at_az - (a0 - m_az), at_el - (e0 - m_el))
        mid = np.empty((3, 3, n_az, n_el + 2 * m_el), np.float32)
        _rows_step(src, m_az, mid)
        v = np.empty((3, 3, n_az, n_el), np.float32)
        _columns_step(mid, m_el, v)
        if _masked(v, ok, r0, c0) == 0:
            return -1
        at_az, at_el = a0, e0
    return int(v.min())


def _feasible_cells(box, cos_b, sin_b, cos_e, sin_e, min_dot, trig
                    ):  # pragma: no cover - compiled by numba (in _bound_loop)
    """As :meth:`_Sky.feasible` and :func:`_trimmed`: the box's feasible cells, and the
    first and last row and column holding one (last row -1: none)."""
    a0, a1, e0, e1 = box[0], box[1], box[2], box[3]
    ok = np.zeros((a1 - a0, e1 - e0), np.bool_)
    r0, r1, c0, c1 = a1 - a0, -1, e1 - e0, -1
    for i in range(a1 - a0):
        along = cos_b[a0 + i] * trig[0] + sin_b[a0 + i] * trig[1]
        for j in range(e1 - e0):
            if (cos_e[e0 + j] * trig[2]) * along + (sin_e[e0 + j] * trig[3]
                                                    - min_dot[e0 + j]) >= 0.0:
                ok[i, j] = True
                r0, r1, c0, c1 = min(r0, i), max(r1, i), min(c0, j), max(c1, j)
    return ok, r0, r1, c0, c1


# The loops below index arrays from 0 within views: an index with an offset of unknown sign
# keeps numba's negative-index check in the loop, and the loop is then not vectorised.

def _paste_into(src, v, d_az, d_el):  # pragma: no cover - compiled by numba (in _bound_loop)
    """As :func:`_paste`: ``v`` into ``src`` where they overlap, cell (i, j) of ``v`` being
    cell (i + d_az, j + d_el) of ``src``."""
    i0, j0 = max(0, -d_az), max(0, -d_el)
    n_i = min(v.shape[2], src.shape[2] - d_az) - i0
    n_j = min(v.shape[3], src.shape[3] - d_el) - j0
    for x in range(3):
        for y in range(3):
            to, of = src[x, y, i0 + d_az:, j0 + d_el:], v[x, y, i0:, j0:]
            for i in range(n_i):
                for j in range(n_j):
                    to[i, j] = of[i, j]


def _masked(v, ok, r0, c0):  # pragma: no cover - compiled by numba (in _bound_loop)
    """No finite cost where the cell is not feasible; the count of finite costs left."""
    inf = np.float32(np.inf)
    feasible = ok[r0:, c0:]
    finite = 0
    for x in range(3):
        for y in range(3):
            cells = v[x, y]
            for i in range(v.shape[2]):
                for j in range(v.shape[3]):
                    cells[i, j] = cells[i, j] if feasible[i, j] else inf
                    finite += cells[i, j] < inf
    return finite


def _cells_step(v0, vp, vn, lo0, lop, lon, hi0, hip, hin, out0, outp, outn, n
                ):  # pragma: no cover - compiled by numba (in the steps)
    """:func:`_axis_step` for ``n`` cells in a row: the costs of resting, turning up and
    turning down (``out0``, ``outp``, ``outn``) from each source cell's rest (``v0``), the
    cell m below turning up (``vp``), the cell m above turning down (``vn``), and the runs'
    minima below (``lo``) and above (``hi``)."""
    one, two = np.float32(1.0), np.float32(2.0)
    for j in range(n):
        full_up, full_down = min(lop[j], hip[j]), min(lon[j], hin[j])
        from_below, from_above = min(lo0[j], lop[j]), min(hi0[j], hin[j])
        anything = min(min(from_below, from_above), min(full_up, full_down))
        out0[j] = min(min(v0[j], lop[j]), min(hin[j], anything + one))
        outp[j] = min(min(vp[j], min(from_below, full_down) + one), anything + two)
        outn[j] = min(min(vn[j], min(from_above, full_up) + one), anything + two)


def _window(runs, width, stride):  # pragma: no cover - compiled by numba (in the steps)
    """In place: each value the least of it and the width - 1 after it ``stride`` apart (by
    doubling); where that reaches past the end the value is meaningless."""
    w, n = 1, len(runs)
    while w < width:
        k = min(w, width - w) * stride  # doubling, then the rest
        for t in range(n - k):
            runs[t] = runs[t] if runs[t] < runs[t + k] else runs[t + k]
        w += k // stride


def _flat_step(src, first, step, block, m, stride, runs, out, out_first, out_step, n
               ):  # pragma: no cover - compiled by numba (in the steps)
    """:func:`_axis_step` over flat stretches of ``block`` cells, a cell's neighbours along
    the axis ``stride`` apart: the three modes of the axis from ``first``, ``step`` apart in
    ``src``; ``n`` results per mode into ``out`` from ``out_first``, ``out_step`` apart."""
    for mode in range(3):
        run, of = runs[mode * block:(mode + 1) * block], src[first + mode * step:]
        for t in range(block):
            run[t] = of[t]
        _window(run, m + 1, stride)
    lo, hi, shift = runs, runs[m * stride:], m * stride
    _cells_step(src[first + shift:], src[first + step:], src[first + 2 * step + 2 * shift:],
                lo, lo[block:], lo[2 * block:], hi, hi[block:], hi[2 * block:],
                out[out_first:], out[out_first + out_step:], out[out_first + 2 * out_step:], n)


def _rows_step(src4, m, out4):  # pragma: no cover - compiled by numba (in _bound_loop)
    """:func:`_axis_step` along axis 2 of ``src4`` (the az cells; modes: axis 0). A row of
    cells is contiguous, so each mode's runs and results are one flat stretch."""
    n_in, width = src4.shape[2], src4.shape[3]
    block, n_out = n_in * width, out4.shape[2] * width
    runs = np.empty(3 * block, np.float32)
    for y in range(3):
        _flat_step(src4.reshape(-1), y * block, 3 * block, block, m, width, runs,
                   out4.reshape(-1), y * n_out, 3 * n_out, n_out)


def _columns_step(src4, m, out4):  # pragma: no cover - compiled by numba (in _bound_loop)
    """:func:`_axis_step` along axis 3 of ``src4`` (the el cells; modes: axis 1): over each
    mode's cells as one flat stretch (the cells near a row's end get meaningless values),
    then each row's first cells kept."""
    n_az, n_in, n_out = src4.shape[2], src4.shape[3], out4.shape[3]
    block = n_az * n_in
    runs = np.empty(3 * block, np.float32)
    flat = np.empty(3 * block, np.float32)
    for x in range(3):
        _flat_step(src4.reshape(-1), 3 * x * block, block, block, m, 1, runs, flat, 0, block,
                   block - 2 * m)
        for y in range(3):
            rows, to = flat[y * block:(y + 1) * block].reshape((n_az, n_in)), out4[x, y]
            for i in range(n_az):
                for j in range(n_out):
                    to[i, j] = rows[i, j]


_loops = compiled.Loops(globals(), helpers=(
    "_feasible_cells", "_paste_into", "_masked", "_cells_step", "_window", "_flat_step",
    "_rows_step", "_columns_step"))
