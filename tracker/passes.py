"""Pass prediction: when a target is above the station's horizon (min elevation + mask).

:func:`find_passes` returns :class:`Pass` values for a window. Satellites start from
skyfield's ``find_events`` on a window padded by one orbit (so a pass in progress at the start
gets its real AOS and one straddling the end its real LOS) at the *lowest* horizon level, and
every other target (Sun, Moon, radio sources, schedules) from coarse vectorised sampling of
``target.observe`` (a schedule file's own points are added to the grid). Both then share one
refinement:

* rise/set: the crossings of ``g(t) = el(t) - station.horizon_at(az(t))`` are bracketed on a
  grid and bisected to :data:`TIME_TOL_S`, all brackets at once (one vectorised call per step);
  a target exactly on the horizon counts as up;
* maximum: golden-section search on the elevation around the grid maximum, all passes at once.

A target that supplies ``hour_angle_deg(station, t_s)`` (the Sun, Moon, planets and fixed
sources in :mod:`tracker.celestial`) also gets the almanac's culminations: TCA is the upper
transit (the hour angle's zero crossing) when one falls inside the pass, and a span holding
more than one upper transit (a circumpolar body) is cut at its lower culminations, one pass per
transit.

So a horizon mask cuts a pass where the target really meets the obstruction, and a pass that
dips behind an obstruction splits in two. Event codes follow skyfield: 0 rise, 1 culminate,
2 set.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from datetime import datetime
from typing import Any

import numpy as np

from tracker.skytrack import SkyTrack
from tracker.station import Station
from tracker.sun import satellite_sun_flags
from tracker.targets import SatelliteTarget, Target
from tracker.timescale import DAY_S, to_datetime, to_posix

TIME_TOL_S = 0.01          # rise/set/TCA refinement tolerance
VISIBLE_SUN_EL_DEG = -6.0  # civil twilight: darker than this, a sunlit satellite is visible
_EDGE_S = 3.0              # margin around find_events crossings (they are good to 0.5 s)
MAX_SAMPLES = 33            # samples per bracket and round of the maximum's search

# Coarse sampling steps for the generic finder, by target kind: fast enough to catch every
# rise of a target moving at most ~15 deg/h, while a whole day costs a few hundred samples.
GENERIC_STEP_S = {"sun": 300.0, "moon": 300.0, "planet": 300.0, "radio": 300.0,
                  "star": 300.0, "satellite": 10.0, "schedule": 10.0}
DEFAULT_GENERIC_STEP_S = 60.0
GENERIC_PAD_S = DAY_S      # a Sun/Moon pass in progress may have risen up to a day earlier


@dataclass(frozen=True)
class Pass:
    """One pass of a target over a station, against the station's horizon (min el + mask).

    Times are aware UTC datetimes. ``aos_known`` is False when the target was already up at
    the start of the searched (padded) span — then ``aos`` is the window start; likewise
    ``los_known`` and the window end. ``always_up`` marks a target above the horizon over the
    whole search (GEO). ``in_progress_at_start`` means AOS is before the window start.
    ``sunlit`` is True if the target is sunlit at any time in the pass; ``visible`` if a
    sunlit satellite is above the horizon while the Sun is below -6 deg at the station.
    """

    target_name: str
    kind: str
    aos: datetime
    tca: datetime
    los: datetime
    max_el_deg: float
    aos_az_deg: float
    tca_az_deg: float
    los_az_deg: float
    duration_s: float
    sunlit: bool = False
    visible: bool = False
    in_progress_at_start: bool = False
    aos_known: bool = True
    los_known: bool = True
    always_up: bool = False
    target: Any = field(default=None, compare=False, repr=False)
    station: Station | None = field(default=None, compare=False, repr=False)

    def track(self, step_s: float = 1.0, pad_s: float = 0.0) -> SkyTrack:
        """The target sampled every ``step_s`` from AOS - pad to LOS + pad (one observe call).

        The last sample is exactly LOS + pad.
        """
        if self.target is None or self.station is None:
            raise ValueError("this Pass has no target/station attached (built by hand?)")
        if not step_s > 0:
            raise ValueError(f"step_s must be > 0, got {step_s}")
        t0 = self.aos.timestamp() - pad_s
        t1 = self.los.timestamp() + pad_s
        t = np.arange(t0, t1, step_s)
        if len(t) == 0 or t1 - t[-1] > 1e-6:
            t = np.append(t, t1)
        return self.target.observe(self.station, t)


# Sampling helpers ------------------------------------------------------------------------------


def _azel_fn(target: Target, station: Station):
    """A vectorised ``t_s -> (az_deg, el_deg)`` for the target (cheapest available call)."""
    if isinstance(target, SatelliteTarget) or callable(getattr(target, "elevation", None)):
        return lambda t_s: target.elevation(station, t_s)

    def fn(t_s):
        track, inverse = _observe_any_order(target, station, t_s)
        return (np.asarray(track.az_deg, dtype=float)[inverse],
                np.asarray(track.el_deg, dtype=float)[inverse])

    return fn


def _observe_any_order(target: Target, station: Station, t_s):
    """``target.observe`` for times in any order with repeats (a SkyTrack needs strictly
    increasing times): returns the track at the sorted unique times and the index array that
    maps them back to ``t_s``."""
    t = np.asarray(t_s, dtype=float)
    unique, inverse = np.unique(t.ravel(), return_inverse=True)
    return target.observe(station, unique), inverse.reshape(t.shape)


def _margin_fn(azel, station: Station):
    """``g(t) = el - horizon(az)``: >= 0 while the target counts as up. NaN counts as down."""

    def g(t_s):
        az, el = azel(t_s)
        out = el - station.horizon_at(az)
        return np.where(np.isfinite(out), out, -1.0)

    return g


def _up(margin: np.ndarray) -> np.ndarray:
    """On or above the horizon counts as up (an azimuth-only schedule sits at el 0)."""
    return margin >= 0.0


def _hour_angle_fn(target: Target, station: Station):
    """The target's ``t_s -> hour angle (deg, (-180, 180])``, or None if it has none."""
    hour_angle = getattr(target, "hour_angle_deg", None)
    if not callable(hour_angle):
        return None

    def ha(t_s):
        return np.asarray(hour_angle(station, np.asarray(t_s, dtype=float)), dtype=float)

    return ha


def _bisect_crossings(g, lo: np.ndarray, hi: np.ndarray, up_lo: np.ndarray) -> np.ndarray:
    """Refine sign changes of ``g`` in ``[lo, hi]`` (``up_lo`` = g(lo) >= 0), all at once.

    Returns the end of the final bracket on the *up* side, so the target is never below the
    horizon at a reported AOS/LOS (it matters to whoever points an antenna there).
    """
    lo = lo.astype(float).copy()
    hi = hi.astype(float).copy()
    if lo.size == 0:
        return lo
    width = float(np.max(hi - lo))
    for _ in range(max(1, math.ceil(math.log2(max(width, TIME_TOL_S) / TIME_TOL_S)))):
        mid = 0.5 * (lo + hi)
        same = _up(g(mid)) == up_lo
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    return np.where(up_lo, lo, hi)


def _refine_max(el_fn, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The time of the maximum of ``el_fn`` on each ``[lo, hi]`` to :data:`TIME_TOL_S`:
    each round samples every bracket :data:`MAX_SAMPLES` times in one vectorised call and
    keeps the two samples around the highest, shrinking the bracket 16-fold (3 calls for
    a 20 s bracket, where a golden-section search needs 17: each call's fixed cost is most
    of a single pass's search)."""
    a = lo.astype(float).copy()
    b = hi.astype(float).copy()
    if a.size == 0:
        return a
    frac = np.linspace(0.0, 1.0, MAX_SAMPLES)
    rows = np.arange(a.size)
    while float(np.max(b - a)) > TIME_TOL_S:
        t = a[:, None] + (b - a)[:, None] * frac[None, :]
        el = np.asarray(el_fn(t.ravel()), dtype=float).reshape(t.shape)
        j = np.clip(np.argmax(np.where(np.isfinite(el), el, -np.inf), axis=1), 1,
                    MAX_SAMPLES - 2)
        a, b = t[rows, j - 1], t[rows, j + 1]
    return 0.5 * (a + b)


# Candidate spans --------------------------------------------------------------------------------


def _lowest_horizon(station: Station) -> float:
    """The lowest horizon level anywhere (the mask is piecewise linear: check its vertices)."""
    if station.mask is None:
        return float(station.min_el_deg)
    return float(np.min(station.horizon_at(np.asarray(station.mask.az_deg))))


def _satellite_spans(target: SatelliteTarget, station: Station, t0: float, t1: float
                     ) -> tuple[list[tuple[float, float, bool, bool]], float, float]:
    """Spans above the lowest horizon level from find_events: (start, end, start_is_rise,
    end_is_set), plus the padded search limits."""
    from tracker.timescale import posix_from_time, time_from_posix

    pad = min(max(target.period_s, 3600.0), 1.5 * DAY_S)
    s0, s1 = t0 - pad, t1 + pad
    target.check_span(t0, t1)  # before find_events: far from the epoch it runs for minutes
    low = _lowest_horizon(station)
    times, events = target.satellite.find_events(
        station.topos(), time_from_posix(s0), time_from_posix(s1), altitude_degrees=low)
    t_ev = np.atleast_1d(posix_from_time(times)) if len(events) else np.zeros(0)
    spans: list[tuple[float, float, bool, bool]] = []
    start: float | None = None
    start_is_rise = False
    # Loop over events (a handful per day), never over samples.
    for t_e, code in zip(t_ev.tolist(), np.asarray(events).tolist(), strict=True):
        if code == 0:
            start, start_is_rise = t_e, True
        elif code == 2:
            if start is None:
                start, start_is_rise = s0, False
            spans.append((start, t_e, start_is_rise, True))
            start = None
        elif start is None:  # a culmination with no rise before it: up at the span start
            start, start_is_rise = s0, False
    if start is not None:
        spans.append((start, s1, start_is_rise, False))
    if not len(events):
        _, el = target.elevation(station, np.array([0.5 * (s0 + s1)]))
        if el[0] > low:
            spans.append((s0, s1, False, False))
    return spans, s0, s1


def _generic_step(target: Target) -> float:
    return float(getattr(target, "search_step_s", 0) or GENERIC_STEP_S.get(
        target.kind, DEFAULT_GENERIC_STEP_S))


def _generic_spans(target: Target, station: Station, g, t0: float, t1: float
                   ) -> tuple[list[tuple[float, float, bool, bool]], float, float]:
    step = _generic_step(target)
    pad = float(getattr(target, "search_pad_s", 0) or GENERIC_PAD_S)
    s0, s1 = t0 - pad, t1 + pad
    n = max(3, math.ceil((s1 - s0) / step) + 1)
    t = np.linspace(s0, s1, n)
    knots = getattr(target, "t_s", None)  # a schedule's own points are where el turns
    if target.kind == "schedule" and knots is not None:
        knots = np.asarray(knots, dtype=float)
        t = np.unique(np.concatenate([t, knots[(knots > s0) & (knots < s1)]]))
    up = _up(g(t))
    return _spans_from_grid(t, up, g), s0, s1


def _spans_from_grid(t: np.ndarray, up: np.ndarray, g
                     ) -> list[tuple[float, float, bool, bool]]:
    """Turn a sampled up/down mask into refined spans (edges of the grid = unknown)."""
    change = np.flatnonzero(up[1:] != up[:-1])
    cross = _bisect_crossings(g, t[change], t[change + 1], up[change])
    return _spans_from_crossings(t, up, change, cross)


def _spans_from_crossings(t: np.ndarray, up: np.ndarray, change: np.ndarray,
                          cross: np.ndarray) -> list[tuple[float, float, bool, bool]]:
    """Spans from a sampled up/down mask and the refined crossing in each changing cell."""
    rising = ~up[change]
    spans = []
    start: float | None = float(t[0]) if up[0] else None
    start_known = False
    for tc, r in zip(cross.tolist(), rising.tolist(), strict=True):
        if r:
            start, start_known = tc, True
        elif start is not None:
            spans.append((start, tc, start_known, True))
            start = None
    if start is not None:
        spans.append((start, float(t[-1]), start_known, False))
    return spans


def _flat_horizon(station: Station) -> bool:
    """True if the horizon is one level all round (no mask, or a mask below the minimum
    elevation everywhere): then find_events' crossings are the real ones."""
    if station.mask is None:
        return True
    return float(np.max(station.horizon_at(np.asarray(station.mask.az_deg)))) == \
        _lowest_horizon(station)


def _refine_satellite_spans(spans, g, s0: float, s1: float, flat: bool):
    """find_events' spans (at the lowest horizon level, good to 0.5 s) refined against the
    real horizon ``g`` to :data:`TIME_TOL_S`.

    On a flat horizon only each crossing's bracket of +-:data:`_EDGE_S` is bisected; a span
    whose brackets do not hold one crossing each (find_events off by more, a grazing pass),
    and every span under a mask, is sampled over its whole length (where the mask may split
    or trim it). Either way, all spans at once: one vectorised call per step."""
    rest = spans
    out: list[tuple[float, float, bool, bool]] = []
    if flat:
        out, rest = _refine_edges(spans, g, s0, s1)
    return sorted(out + _refine_on_grid(rest, g, s0, s1))


def _refine_edges(spans, g, s0: float, s1: float):
    """Bisect each known rise/set in its +-:data:`_EDGE_S` bracket (flat horizon). Returns
    the refined spans and those whose brackets were not sound."""
    if not spans:
        return [], []
    rows = []  # (lo, hi, up at lo, span index, a crossing to bisect)
    for k, (a, b, a_known, b_known) in enumerate(spans):
        mid = 0.5 * (a + b)  # up, between a rise and its set at the same level
        # an unknown edge is the search limit, where the target must be up: a point check
        rows.append((max(a - _EDGE_S, s0), min(a + _EDGE_S, mid), False, k, True) if a_known
                    else (a, a, True, k, False))
        rows.append((max(b - _EDGE_S, mid), min(b + _EDGE_S, s1), True, k, True) if b_known
                    else (b, b, True, k, False))
    lo_a, hi_a, up_lo_a, owner_a, known_a = (np.array(col) for col in zip(*rows, strict=True))
    lo_a, hi_a = lo_a.astype(float), hi_a.astype(float)
    up_lo_a, known_a = up_lo_a.astype(bool), known_a.astype(bool)
    up = _up(g(np.concatenate([lo_a, hi_a])))
    n = lo_a.size
    edge = known_a & (hi_a > lo_a)
    sound = (up[:n] == up_lo_a) & np.where(edge, up[n:] != up_lo_a, up[n:]) & (
        edge | ~known_a)
    bad = np.zeros(len(spans), dtype=bool)
    np.logical_or.at(bad, owner_a, ~sound)
    use = edge & ~bad[owner_a]
    when = lo_a.copy()
    when[use] = _bisect_crossings(g, lo_a[use], hi_a[use], up_lo_a[use])
    out = []
    for k, (a, b, a_known, b_known) in enumerate(spans):
        if not bad[k]:
            first, second = when[owner_a == k].tolist()
            out.append((first if a_known else a, second if b_known else b, a_known, b_known))
    return out, [span for span, no in zip(spans, bad.tolist(), strict=True) if no]


def _refine_on_grid(spans, g, s0: float, s1: float):
    """Split/trim the lowest-level spans where ``g`` (the real horizon) says down: each span
    sampled every 5 s (long ones in 1500 steps), all spans in one call, every changing cell
    bisected at once."""
    if not spans:
        return []
    grids, bounds = [], []
    for a, b, a_known, b_known in spans:
        lo = a - _EDGE_S if a_known else a
        hi = b + _EDGE_S if b_known else b
        lo, hi = max(lo, s0), min(hi, s1)
        step = 5.0 if hi - lo < 7200.0 else (hi - lo) / 1500.0
        grids.append(np.linspace(lo, hi, max(3, math.ceil((hi - lo) / step) + 1)))
        bounds.append((lo, hi))
    t = np.concatenate(grids)
    up = _up(g(t))
    seg = np.repeat(np.arange(len(grids)), [len(x) for x in grids])
    change = np.flatnonzero((up[1:] != up[:-1]) & (seg[1:] == seg[:-1]))
    cross = _bisect_crossings(g, t[change], t[change + 1], up[change])
    out = []
    offset = 0
    for k, (lo, hi) in enumerate(bounds):
        size = len(grids[k])
        mine = (change >= offset) & (change < offset + size - 1)
        pieces = _spans_from_crossings(t[offset:offset + size], up[offset:offset + size],
                                       change[mine] - offset, cross[mine])
        out += [(c, d, c_known or (c > lo), d_known or (d < hi))
                for c, d, c_known, d_known in pieces]
        offset += size
    return out


# Culminations from the hour angle (targets that supply one) ------------------------------------


def _culminations(ha_fn, bounds: list[tuple[float, float]], step: float
                  ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per interval: the upper transits (hour angle rising through 0) and lower culminations
    (the hour angle wrapping from +180 to -180), bracketed on one grid over every interval and
    bisected to :data:`TIME_TOL_S`, all at once."""
    grids = [np.linspace(lo, hi, max(3, math.ceil((hi - lo) / step) + 1)) for lo, hi in bounds]
    t = np.concatenate(grids)
    seg = np.repeat(np.arange(len(grids)), [len(g) for g in grids])
    ha = ha_fn(t)
    d = np.diff(ha)
    inside = seg[1:] == seg[:-1]
    upper = np.flatnonzero(inside & (ha[:-1] < 0) & (ha[1:] >= 0) & (d < 180))
    lower = np.flatnonzero(inside & (d < -180))
    idx = np.concatenate([upper, lower])
    is_upper = np.arange(idx.size) < upper.size

    def g(x):  # >= 0 before the crossing: -HA before a transit, HA before the wrap
        h = ha_fn(x)
        return np.where(is_upper, -h, np.where(h > 0, 1.0, -1.0))

    when = _bisect_crossings(g, t[idx], t[idx + 1], np.ones(idx.size, dtype=bool))
    which = seg[idx]
    return ([when[is_upper & (which == k)] for k in range(len(grids))],
            [when[~is_upper & (which == k)] for k in range(len(grids))])


def _cut_at_culminations(spans, ha_fn, step: float, t0: float, t1: float):
    """Spans cut at lower culminations when they hold more than one upper transit (a
    circumpolar body: one piece per transit, as an almanac lists it). Returns the pieces, the
    upper transit inside each (NaN if none) and whether each comes from a span that was up
    over the whole search."""
    bounds = [(a if a_known else max(a, t0), b if b_known else min(b, t1))
              for a, b, a_known, b_known in spans]
    transits, lowers = _culminations(ha_fn, bounds, step)
    pieces, tca, always = [], [], []
    for (a, b, a_known, b_known), (lo, hi), up, low in zip(spans, bounds, transits, lowers,
                                                           strict=True):
        edges = [lo, *(low.tolist() if len(up) > 1 else []), hi]
        last = len(edges) - 2
        for i, (x, y) in enumerate(itertools.pairwise(edges)):
            pieces.append((a if i == 0 else x, b if i == last else y,
                           a_known and i == 0, b_known and i == last))
            hit = up[(up >= x) & (up <= y)]
            tca.append(float(hit[0]) if hit.size else math.nan)
            always.append(not a_known and not b_known)
    return pieces, np.array(tca), np.array(always, dtype=bool)


# The finder --------------------------------------------------------------------------------------


def find_passes(target: Target, station: Station, start: datetime | float,
                end: datetime | float, min_el_deg: float | None = None) -> list[Pass]:
    """Passes of ``target`` over ``station`` that overlap ``[start, end]``, sorted by AOS.

    ``min_el_deg`` overrides the station's minimum elevation (the mask still applies). A pass
    in progress at ``start`` is included with its real AOS; one running past ``end`` with its
    real LOS. A target that never rises gives ``[]``; one that is up the whole time (GEO)
    gives one Pass with ``always_up=True`` spanning the window, except that a target with an
    hour angle (Sun, Moon, planets, fixed sources) is cut at its lower culminations, one Pass
    per upper transit, and its TCA is the upper transit when one falls inside the pass. Raises
    :class:`~tracker.errors.PropagationError` for elements that cannot be propagated.
    """
    t0, t1 = to_posix(start), to_posix(end)
    if not t1 > t0:
        raise ValueError(f"the window end must be after its start ({start} .. {end})")
    if min_el_deg is not None:
        station = replace(station, min_el_deg=float(min_el_deg))
    azel = _azel_fn(target, station)
    g = _margin_fn(azel, station)
    if isinstance(target, SatelliteTarget):
        spans, s0, s1 = _satellite_spans(target, station, t0, t1)
        spans = _refine_satellite_spans(spans, g, s0, s1, _flat_horizon(station))
    else:
        spans, s0, s1 = _generic_spans(target, station, g, t0, t1)
    spans = [s for s in spans if s[1] > t0 and s[0] < t1]
    ha_fn = _hour_angle_fn(target, station)
    transit = always = None
    if spans and ha_fn is not None:
        spans, transit, always = _cut_at_culminations(spans, ha_fn, _generic_step(target),
                                                      t0, t1)
        keep = np.array([s[1] > t0 and s[0] < t1 for s in spans], dtype=bool)
        spans = [s for s, k in zip(spans, keep, strict=True) if k]
        transit, always = transit[keep], always[keep]
    if not spans:
        return []
    return _build_passes(target, station, spans, azel, t0, t1, transit, always)


def _build_passes(target, station, spans, azel, t0: float, t1: float,
                  transit: np.ndarray | None = None, always: np.ndarray | None = None
                  ) -> list[Pass]:
    """Pass values for refined spans; ``transit`` (NaN where none) overrides the TCA time and
    ``always`` the always-up flag (both from the hour angle, for celestial targets)."""
    a = np.array([s[0] for s in spans])
    b = np.array([s[1] for s in spans])
    a_known = np.array([s[2] for s in spans])
    b_known = np.array([s[3] for s in spans])
    # The reported interval: real AOS/LOS when known, else the window edge.
    aos = np.where(a_known, a, np.maximum(a, t0))
    los = np.where(b_known, b, np.minimum(b, t1))

    # Maximum: coarse grid over each pass (highest of several culminations), then golden
    # sampling of the neighbourhood of the best grid point; all passes in one call per round.
    n_grid = 64
    frac = np.linspace(0.0, 1.0, n_grid)
    grid = aos[:, None] + (los - aos)[:, None] * frac[None, :]
    _, el_grid = azel(grid.ravel())
    el_grid = np.where(np.isfinite(el_grid), el_grid, -np.inf).reshape(grid.shape)
    best = np.argmax(el_grid, axis=1)
    rows = np.arange(len(spans))
    lo = grid[rows, np.maximum(best - 1, 0)]
    hi = grid[rows, np.minimum(best + 1, n_grid - 1)]
    tca = _refine_max(lambda t: azel(t)[1], lo, hi)
    end_vals = np.concatenate([aos, tca, los])
    az_all, el_all = azel(end_vals)
    k = len(spans)
    aos_az, tca_az, los_az = az_all[:k], az_all[k:2 * k], az_all[2 * k:]
    tca_el = el_all[k:2 * k]
    # The golden search is bracketed by grid neighbours; keep the grid maximum if it was higher.
    grid_max = el_grid[rows, best]
    use_grid = grid_max > tca_el
    tca = np.where(use_grid, grid[rows, best], tca)
    max_el = np.maximum(tca_el, grid_max)
    if np.any(use_grid):
        tca_az = np.where(use_grid, azel(tca)[0], tca_az)
    if transit is not None and np.any(np.isfinite(transit)):
        tca, tca_az = _at_transit(azel, tca, tca_az, transit)
    if always is None:
        always = ~a_known & ~b_known

    sunlit, visible = _sunlit_visible(target, station, aos, los)
    passes = []
    for i in range(k):
        passes.append(Pass(
            target_name=target.name, kind=target.kind,
            aos=to_datetime(aos[i]), tca=to_datetime(tca[i]), los=to_datetime(los[i]),
            max_el_deg=float(max_el[i]), aos_az_deg=float(aos_az[i]),
            tca_az_deg=float(tca_az[i]), los_az_deg=float(los_az[i]),
            duration_s=float(los[i] - aos[i]), sunlit=bool(sunlit[i]),
            visible=bool(visible[i]), in_progress_at_start=bool(a[i] < t0),
            aos_known=bool(a_known[i]), los_known=bool(b_known[i]),
            always_up=bool(always[i]),
            target=target, station=station))
    passes.sort(key=lambda p: p.aos)
    return passes


def _at_transit(azel, tca: np.ndarray, tca_az: np.ndarray, transit: np.ndarray):
    """TCA (and its azimuth) moved to the upper transit where a pass has one; the maximum
    elevation stays the searched maximum (the Moon's highest point is minutes off transit)."""
    has = np.isfinite(transit)
    az_t, _ = azel(transit[has])
    tca = tca.copy()
    tca_az = np.asarray(tca_az, dtype=float).copy()
    tca[has] = transit[has]
    tca_az[has] = az_t
    return tca, tca_az


def _sunlit_visible(target, station: Station, aos: np.ndarray, los: np.ndarray):
    """Per pass: sunlit at any sample, and visible (sunlit, up, Sun below -6 deg), from the
    low-precision Sun (:mod:`tracker.sun`)."""
    k = len(aos)
    no = np.zeros(k, dtype=bool)
    if not isinstance(target, SatelliteTarget):
        return no, no.copy()
    n = 40
    frac = np.linspace(0.0, 1.0, n)
    t = (aos[:, None] + (los - aos)[:, None] * frac[None, :]).ravel()
    lit, sun_sin_el = satellite_sun_flags(target.satellite.model, t, station.lat_deg,
                                          station.lon_deg)
    lit = lit.reshape(k, n)
    dark = sun_sin_el.reshape(k, n) < math.sin(math.radians(VISIBLE_SUN_EL_DEG))
    return lit.any(axis=1), (lit & dark).any(axis=1)
