"""Aim-point and deadband policy for live tracking (pure numpy, no I/O, no clock).

The live loop follows a planned mount path ``A(t), E(t)`` (mechanical azimuth, elevation)
but does not send every sample: relays wear out and the G-5500 has a start delay. It waits
while the antenna is within ``deadband_deg`` of the path, and when it must move it aims
*ahead* so the target drifts through the beam.

Gpredict aims at "the furthest future point still within the threshold of the current
target" and ignores the time the rotator needs to get there, so on fast passes the antenna
arrives late and the hold is short. Here every candidate aim point on the path ahead is
played through THE motor model (:class:`tracker.mount.AxisMotor`: start delay, rate,
quantisation, limits) and scored by the real great-circle pointing error until the next
command it would cause:

* the *hold* of a candidate is the time until the antenna, arrived at the aim point, is more
  than the deadband off the path (when the loop would have to command again);
* its *peak* is the largest predicted error over that hold (at least ``min_window_s``), slew
  included.

Candidates move both axes, or only one (the other keeps its target: one relay click
instead of two); where the path passes within the deadband of the zenith, also each azimuth
with the elevation at the zenith (an azimuth swing there sweeps the antenna round the zenith
below it). The chosen candidate keeps the peak within the deadband (or as close to the
best achievable as ``peak_slack_deg`` when the rotator lags) with the longest hold per motor
start, and among candidates with nearly that value, the smallest peak: the aim point that
minimises the maximum error until the next expected command, for the fewest motor starts.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from tracker.geometry import MountPath, pointing_error_rows_deg
from tracker.mount import AxisMotor, drive_axis, moves_from_rest
from tracker.skytrack import (
    angle_between_components_deg,
    angle_between_scalar_deg,
    azel_to_enu_scalar,
)

# What one command costs besides its motor starts, in starts: the bytes and the read-back
# disturbance of a command that starts nothing (a retarget of a running motor).
COMMAND_COST_STARTS = 0.3


@dataclass(frozen=True)
class Aim:
    """One chosen command and what the policy expects from it."""

    az_m_deg: float          # quantised, clamped: what the motor will really go to
    el_deg: float | None
    aim_t_s: float           # the path time whose point is aimed at
    hold_s: float            # expected time from now until the next command
    peak_error_deg: float    # predicted max great-circle error over the hold
    arrival_s: float         # predicted arrival time at the aim point (UTC POSIX s)
    candidates: int          # how many distinct aim points were compared
    starts: int = 0          # motor starts the command causes (0, 1 or 2)


def _predict(axis: AxisMotor, target_deg: float, t0_s: float,
             ts: np.ndarray) -> tuple[np.ndarray, float, int]:
    """``(positions over ts, arrival time, motor starts)`` if ``target_deg`` is commanded at
    ``t0_s`` (on a copy: ``axis`` is not changed)."""
    a = copy.copy(axis)
    pos, starts = drive_axis(a, [t0_s], [target_deg], ts)
    return pos, a.arrival_s(), starts


# Rounding room when a bound on the error decides instead of the samples (the error itself is
# computed to ~1e-12 deg).
_BOUND_SLACK_DEG = 1e-6


def _quantise(axis: AxisMotor, targets_deg: np.ndarray) -> np.ndarray:
    """:meth:`AxisMotor.quantise` of each of ``targets_deg`` (the same rounding: half to
    even, then the limits)."""
    res = axis.resolution_deg
    # np.minimum(np.maximum(...)) is np.clip's result at a fraction of its call cost.
    return np.minimum(np.maximum(np.round(np.asarray(targets_deg, dtype=float) / res) * res,
                                 axis.min_deg), axis.max_deg)


# ``f(i0, i1)``: values over the samples ``ts[i0:i1]`` (computed when asked for).
Columns = Callable[[int, int], np.ndarray]


def _predict_all(axis: AxisMotor, targets_deg: np.ndarray, t0_s: float, ts: np.ndarray
                 ) -> tuple[Columns, list[float], list[int]]:
    """:func:`_predict` for each of ``targets_deg``: ``positions(i0, i1)`` (the positions
    ``(k, i1 - i0)`` over ``ts[i0:i1]``), arrival times and motor starts (one per target),
    for all targets at once and only over the columns asked for. An axis at rest takes
    :func:`~tracker.mount.drive_axis`'s closed form for one command; a running one
    :meth:`AxisMotor.command`'s retarget (no new start delay while it keeps its direction),
    in the same arithmetic; a jammed one steps each. The targets are few (the distinct
    quantised ones of an axis): arrivals and starts are worked out on floats."""
    if axis.jammed:
        sims = [_predict(axis, float(v), t0_s, ts) for v in targets_deg]
        pos_all = np.array([p for p, _a, _s in sims])
        return (lambda i0, i1: pos_all[:, i0:i1], [a for _p, a, _s in sims],
                [s for _p, _a, s in sims])
    p0 = float(axis.position(t0_s))
    cmd = _quantise(axis, targets_deg)
    rate_deg_s, start_delay_s = axis.rate_deg_s, axis.start_delay_s
    if axis.moving(t0_s):
        was = axis.direction(t0_s)
        seg_t0_s, _p, _target, seg_delay_s, _rate, _jammed = axis.segment()
        keep_delay_s = max(0.0, seg_t0_s + seg_delay_s - t0_s)
        dists = (cmd - p0).tolist()
        news = [0 if abs(d) < 1e-9 else (1 if d > 0 else -1) for d in dists]
        delays = [keep_delay_s if new == was else start_delay_s if new != 0 else 0.0
                  for new in news]
        arrival = [t0_s + w + abs(d) / rate_deg_s for d, w in zip(dists, delays, strict=True)]
        sign = np.array([math.copysign(1.0, d) for d in dists])[:, None]
        span = np.array([abs(d) for d in dists])[:, None]
        wait = np.array(delays)[:, None]

        def running(i0: int, i1: int) -> np.ndarray:
            # AxisMotor.position's operations in its order: the same numbers as stepping.
            t = ts[i0:i1]
            pos = p0 + sign * np.minimum(np.maximum((t[None, :] - t0_s - wait) * rate_deg_s,
                                                    0.0), span)
            if len(t) and t[0] < t0_s:      # (samples are ascending)
                early = t < t0_s
                pos[:, early] = axis.position(t[early])
            return pos

        return running, arrival, [int(new != 0 and new != was) for new in news]
    steps = [abs(c - p0) for c in cmd.tolist()]
    # np.where(step > 1e-9, delay, 0.0) and the rest of the closed form, in its order
    arrival = [t0_s + (start_delay_s if step > 1e-9 else 0.0) + step / rate_deg_s
               for step in steps]
    moves = moves_from_rest(p0, cmd[:, None], rate_deg_s, start_delay_s)

    def positions(i0: int, i1: int) -> np.ndarray:
        t = ts[i0:i1]
        pos = moves(t[None, :] - t0_s)
        if len(t) and t[0] < t0_s:      # (samples are ascending)
            pos[:, t < t0_s] = p0
        return pos

    return positions, arrival, [int(step > 1e-9) for step in steps]


def _at(path: MountPath, t_s: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The path's mechanical az and el at ``t_s`` (el 0 on an azimuth-only path)."""
    az, el = path.mount_at(t_s)
    return az, np.zeros_like(az) if el is None else el


def predicted_error(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor | None,
                    t0_s: float, ts: ArrayLike) -> np.ndarray:
    """Error (deg) over ``ts`` if nothing new is commanded: the motors finish what they do."""
    ts = np.asarray(ts, dtype=float)
    az = az_axis.position(ts)
    el = el_axis.position(ts) if el_axis is not None else np.zeros_like(ts)
    return path.error_deg(ts, az, el)


def needs_command(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor | None, t0_s: float,
                  deadband_deg: float, lookahead_s: float, step_s: float = 0.25) -> bool:
    """True when the antenna, left alone, would leave the deadband within ``lookahead_s``.

    Looking ahead by one cycle plus the start delay makes the loop move *before* the target
    leaves the deadband instead of after it, so the error stays within it.
    """
    # Once a cycle: scalar math on the same instants as ``np.arange`` would give.
    end_s = path.end_s
    n = math.ceil((max(lookahead_s, step_s) + 1e-9) / step_s)
    if t0_s > end_s:
        return False
    az0 = az_axis.position(t0_s)
    el0 = el_axis.position(t0_s) if el_axis is not None else 0.0
    err0 = path.error_deg(t0_s, az0, el0)
    if err0 > deadband_deg:
        return True
    # The error can grow by at most what the target and each axis move meanwhile (an axis
    # runs one way toward its target): well inside the deadband, no sample can leave it.
    t_last = t0_s + (n - 1) * step_s
    growth = path.target_travel_bound_deg(t0_s, t_last) + abs(az_axis.position(t_last) - az0)
    if el_axis is not None:
        growth += abs(el_axis.position(t_last) - el0)
    if err0 + growth < deadband_deg - _BOUND_SLACK_DEG:
        return False
    for k in range(1, n):
        t = t0_s + k * step_s
        if t > end_s:
            break
        el = el_axis.position(t) if el_axis is not None else 0.0
        if path.error_deg(t, az_axis.position(t), el) > deadband_deg:
            return True
    return False


def quiet_until_s(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor | None, t0_s: float,
                  deadband_deg: float, lookahead_s: float, step_s: float = 0.25,
                  first_s: float = 0.5, horizon_s: float = 64.0) -> float | None:
    """The latest time ``T`` found such that :func:`needs_command` is False at every ``t`` in
    ``[t0_s, T]`` (with the same look-ahead and step, any deadband from ``deadband_deg`` up)
    while the axes keep their current commands, so the live loop need not ask it again before
    ``T``; None when not even ``t0_s`` is shown so (then only :func:`needs_command` can tell).

    :func:`needs_command`'s bound, from ``t0_s``: the error now plus what the target
    (:meth:`MountPath.target_travel_bound_deg`) and each axis (one way, toward its target) can
    move by then keeps every later error inside. Tried ``0, first_s, 2 first_s, 4 first_s,
    ...`` ahead, up to ``horizon_s``."""
    n = math.ceil((max(lookahead_s, step_s) + 1e-9) / step_s)
    window_s = (n - 1) * step_s            # needs_command samples t .. t + window_s
    if t0_s > path.end_s:
        return None
    az0 = az_axis.position(t0_s)
    el0 = el_axis.position(t0_s) if el_axis is not None else 0.0
    # An axis on its target stays there: no need to ask where it will be.
    az_runs = az_axis.target_deg != az0
    el_runs = el_axis is not None and el_axis.target_deg != el0
    if not az_runs and not el_runs:
        # Standing still: the path's samples bound the error far ahead (MountPath).
        within_s = path.fixed_mount_within_s(az0, el0, t0_s, deadband_deg - _BOUND_SLACK_DEG,
                                             t0_s + horizon_s + window_s)
        rest_until = min(within_s - window_s, t0_s + horizon_s)
        return rest_until if rest_until >= t0_s else None
    room = deadband_deg - _BOUND_SLACK_DEG - path.error_deg(t0_s, az0, el0)
    until: float | None = None
    ahead_s = 0.0
    while ahead_s <= horizon_s:
        t = t0_s + ahead_s + window_s
        growth = path.target_travel_bound_deg(t0_s, t)
        if az_runs:
            growth += abs(az_axis.position(t) - az0)
        if el_runs and el_axis is not None:
            growth += abs(el_axis.position(t) - el0)
        if growth >= room:
            break
        until = t0_s + ahead_s
        ahead_s = 2.0 * ahead_s if ahead_s else first_s
    return until


def choose_aim(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor | None, t0_s: float,
               deadband_deg: float, step_s: float = 0.5, horizon_s: float = 180.0,
               min_window_s: float | None = None, peak_slack_deg: float = 0.25,
               hold_fraction: float = 0.9) -> Aim:
    """The best aim point on ``path`` ahead of ``t0_s`` for motors in their current state.

    ``az_axis``/``el_axis`` are the motor states as the loop believes them (they are copied,
    never mutated). Candidates are path points every ``step_s`` up to ``horizon_s`` ahead (or
    the end of the path); each is simulated with the motor model and scored as described in
    the module docstring.
    """
    t_end = min(path.end_s, t0_s + horizon_s)
    ts = np.arange(t0_s, max(t_end, t0_s) + 1e-9, step_s)
    if len(ts) < 2:
        ts = np.array([t0_s, t0_s + step_s])
    # The samples are computed in the blocks the errors are (``_blocks``), only as far as
    # the candidates and their errors need them.
    dirs: dict[tuple[int, int], np.ndarray] = {}

    def target_dir(i0: int, i1: int) -> np.ndarray:           # (i1 - i0, 3)
        if (i0, i1) not in dirs:
            dirs[i0, i1] = path.target_enu(ts[i0:i1])
        return dirs[i0, i1]

    # Candidates beyond where the target will be once it has moved well past the deadband
    # cannot be the best; cut them to keep the loop cheap.
    cur_dir = target_dir(*_blocks(len(ts))[0])[0]             # ts[0] is t0_s
    here = azel_to_enu_scalar(
        (float(az_axis.position(t0_s)) + path.stop_bearing_deg) % 360.0,
        float(el_axis.position(t0_s)) if el_axis is not None else 0.0)
    lag_deg = angle_between_scalar_deg(here, cur_dir.tolist())
    n_cand = _within_reach(path, ts, target_dir, cur_dir,
                           2.5 * deadband_deg + lag_deg + 2.0)
    cand_az, cand_el = _at(path, ts[:n_cand])
    q_az = _quantise(az_axis, cand_az)
    q_el = _quantise(el_axis, cand_el) if el_axis is not None else np.zeros(n_cand)
    # Near the zenith an azimuth swing costs little error at the zenith itself, and much on
    # the way round below it: there the antenna may go up while azimuth turns.
    zenith_el = None
    if el_axis is not None and el_axis.min_deg <= 90.0 <= el_axis.max_deg and float(
            np.min(np.abs(cand_el - 90.0))) < deadband_deg:
        zenith_el = float(_quantise(el_axis, np.array([90.0]))[0])
    c_az, c_el, c_t = _distinct_candidates(q_az, q_el, ts[:n_cand], az_axis.target_deg,
                                           el_axis.target_deg if el_axis is not None else None,
                                           zenith_el)
    k = len(c_az)

    # The axes are independent: simulate each distinct target once per axis.
    u_az, i_az = _unique_inverse(c_az)
    pos_az, arr_az, st_az = _predict_all(az_axis, u_az, t0_s, ts)
    if el_axis is not None:
        u_el, i_el = _unique_inverse(c_el)
        pos_el, arr_el, st_el = _predict_all(el_axis, u_el, t0_s, ts)
    else:
        i_el = [0] * k
        pos_el = lambda i0, i1: np.zeros((1, i1 - i0))  # noqa: E731
        arr_el, st_el = [t0_s], [0]
    # Per candidate (a few dozen): the later axis's arrival, both axes' starts.
    arrival_l = [max(arr_az[a], arr_el[e]) for a, e in zip(i_az, i_el, strict=True)]
    starts = [st_az[a] + st_el[e] for a, e in zip(i_az, i_el, strict=True)]
    arrival = np.array(arrival_l)
    if min_window_s is None:
        min_window_s = 4.0 * step_s
    rows_az, rows_el = np.array(i_az, dtype=np.intp), np.array(i_el, dtype=np.intp)

    def err_cols(i0: int, i1: int, rows: np.ndarray) -> np.ndarray:   # (len(rows), i1 - i0)
        pa, ia = pos_az(i0, i1), rows_az[rows]
        pe, ie = pos_el(i0, i1), rows_el[rows]
        if len(rows) < k:
            # A later block, for the few candidates still undecided: the trigonometry only
            # of the axis rows they use.
            pa, ia = _rows_used(pa, ia)
            pe, ie = _rows_used(pe, ie)
        return pointing_error_rows_deg(pa, pe, ia, ie, path.stop_bearing_deg,
                                       target_dir(i0, i1))

    hold_a, peak_a = _hold_and_peak(err_cols, ts, t0_s, arrival, deadband_deg, min_window_s,
                                    step_s)
    hold, peak = hold_a.tolist(), peak_a.tolist()
    # Slack above the best peak only when the deadband cannot be kept anyway (the rotator
    # lags); otherwise a longer hold must not buy a peak outside the deadband.
    best_peak = min(peak)
    usable = [True] * k
    if best_peak > deadband_deg:
        # Far off the target (a pass joined under way, the antenna left behind): the errors
        # while slewing are every candidate's own, and the lowest peak can belong to one
        # that never reaches the deadband (moving only the quicker axis). Only candidates
        # that arrive inside the deadband can end the catch-up; choose among them.
        first_after = np.minimum(np.searchsorted(ts, arrival - 1e-9), len(ts) - 1)
        acquires = (arrival <= ts[-1]) & (t0_s + hold_a > ts[first_after] + 1e-9)
        if acquires.any():
            usable = acquires.tolist()
            best_peak = min(p for p, u in zip(peak, usable, strict=True) if u)
    level = deadband_deg if best_peak <= deadband_deg else best_peak + peak_slack_deg
    pick = _pick(hold, peak, starts, [u and p <= level for u, p in zip(usable, peak,
                                                                         strict=True)],
                 hold_fraction)
    return Aim(az_m_deg=c_az[pick], el_deg=c_el[pick] if el_axis is not None else None,
               aim_t_s=c_t[pick], hold_s=hold[pick], peak_error_deg=peak[pick],
               arrival_s=arrival_l[pick], candidates=k, starts=starts[pick])


def _rows_used(values: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows of ``values`` that ``index`` names, and ``index`` into those (``values`` and
    ``index`` themselves when it names them all)."""
    used = sorted(set(index.tolist()))
    if len(used) == len(values):
        return values, index
    at = {r: j for j, r in enumerate(used)}
    return values[used], np.array([at[r] for r in index.tolist()], dtype=np.intp)


def _pick(hold: list[float], peak: list[float], starts: list[int], ok: list[bool],
          hold_fraction: float) -> int:
    """Index of the chosen candidate: of those ``ok``, the ones whose hold per motor start
    (and a little per command: the fewest relay clicks and bytes for the time the error
    stays bounded) comes within ``hold_fraction`` of the best, the one with the smallest
    peak (the first on a tie; the first candidate when none is ``ok``)."""
    value = [h / (s + COMMAND_COST_STARTS) for h, s in zip(hold, starts, strict=True)]
    best = max((v for v, o in zip(value, ok, strict=True) if o), default=-math.inf)
    floor = hold_fraction * best
    pick, pick_peak = 0, math.inf
    for i, (v, o, p) in enumerate(zip(value, ok, peak, strict=True)):
        if o and v >= floor and p < pick_peak:
            pick, pick_peak = i, p
    return pick


def _within_reach(path: MountPath, ts: np.ndarray, target_dir: Columns, cur_dir: np.ndarray,
                  reach_deg: float) -> int:
    """How many of ``ts`` come before the first whose target is more than ``reach_deg`` from
    ``cur_dir`` (at least 1; all when none is)."""
    t0_s = float(ts[0])
    c0, c1, c2 = cur_dir.tolist()
    for i0, i1 in _blocks(len(ts)):
        # The target moves at most its travel bound: a block it cannot leave the reach in
        # needs no samples (the errors may never get that far).
        if path.target_travel_bound_deg(t0_s, float(ts[i1 - 1])) < reach_deg - _BOUND_SLACK_DEG:
            continue
        d = target_dir(i0, i1)
        # angle_between_deg(d, cur_dir), from the components at hand
        off_deg = angle_between_components_deg(d[:, 0], d[:, 1], d[:, 2], c0, c1, c2)
        beyond = np.flatnonzero(off_deg > reach_deg)
        if len(beyond):
            return max(1, i0 + int(beyond[0]))
    return len(ts)


def _distinct_candidates(q_az: np.ndarray, q_el: np.ndarray, c_ts: np.ndarray, keep_az: float,
                         keep_el: float | None, zenith_el: float | None = None
                         ) -> tuple[list[float], list[float], list[float]]:
    """The candidate ``(az, el, aim time)`` rows from the quantised path points ``q_az``,
    ``q_el`` at ``c_ts``: each point, then (with an elevation axis, ``keep_el`` not None)
    each moving only azimuth, then only elevation (the other keeps its target: one relay
    click instead of two), then (``zenith_el`` not None) each azimuth with the elevation
    at the zenith. The first of each distinct (az, el), in that order, but not the targets
    the axes already have (unless that is all there is)."""
    # A candidate equal to the one before it in its group is never a first: dropping those
    # leaves a few to sort out.
    moves_az = np.empty(len(q_az), dtype=bool)
    moves_az[0] = True
    np.not_equal(q_az[1:], q_az[:-1], out=moves_az[1:])
    moves_el = np.empty(len(q_el), dtype=bool)
    moves_el[0] = True
    np.not_equal(q_el[1:], q_el[:-1], out=moves_el[1:])
    az, el, ts = q_az.tolist(), q_el.tolist(), c_ts.tolist()
    rows = np.flatnonzero(moves_az | moves_el).tolist()
    pairs, times = [(az[i], el[i]) for i in rows], [ts[i] for i in rows]
    if keep_el is not None:
        rows_az, rows_el = np.flatnonzero(moves_az).tolist(), np.flatnonzero(moves_el).tolist()
        pairs += [(az[i], keep_el) for i in rows_az]
        pairs += [(keep_az, el[i]) for i in rows_el]
        times += [ts[i] for i in rows_az]
        times += [ts[i] for i in rows_el]
        if zenith_el is not None:
            pairs += [(az[i], zenith_el) for i in rows_az]
            times += [ts[i] for i in rows_az]
    else:
        keep_el = 0.0
    # Each distinct pair in the order it first comes, with the time it first comes at (of
    # repeated keys, a dict keeps the last value written: the first, written in reverse).
    first_t = dict(zip(reversed(pairs), reversed(times), strict=True))
    distinct = list(dict.fromkeys(pairs))
    kept = [p for p in distinct if abs(p[0] - keep_az) >= 1e-9 or abs(p[1] - keep_el) >= 1e-9]
    kept = kept or distinct
    return [a for a, _e in kept], [e for _a, e in kept], [first_t[p] for p in kept]


# Candidate errors are computed this many samples at a time, then twice as many more, ...
# until they decide every hold.
_ERROR_BLOCK = 64


def _blocks(n: int) -> list[tuple[int, int]]:
    """The column ranges ``(i0, i1)`` of ``n`` samples, in the order the errors take them:
    ``_ERROR_BLOCK`` first, each next block doubling what is done."""
    out, m = [], min(_ERROR_BLOCK, n)
    out.append((0, m))
    while m < n:
        out.append((m, min(2 * m, n)))
        m = out[-1][1]
    return out


def _unique_inverse(values: list[float]) -> tuple[np.ndarray, list[int]]:
    """``np.unique(values, return_inverse=True)`` for the few candidate targets of an axis
    (a dict, at a fraction of its call cost)."""
    distinct = sorted(set(values))
    index = {v: k for k, v in enumerate(distinct)}
    return np.array(distinct), [index[v] for v in values]


def _hold_and_peak(err_cols: Callable[[int, int, np.ndarray], np.ndarray], ts: np.ndarray,
                   t0_s: float, arrival: np.ndarray, deadband_deg: float, min_window_s: float,
                   step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each candidate's hold and peak error (module docstring) from its errors over ``ts``
    (``err_cols(i0, i1, rows)``: the columns ``i0:i1`` of the candidates ``rows``). Columns
    are computed in blocks, only as far as needed, and a block only for the candidates it
    can still change: once a candidate has left the deadband and no later sample is in its
    window, the rest cannot change its hold or its peak."""
    n = len(ts)
    k = len(arrival)
    # The error before the quickest candidate can arrive is the same for all of them (the
    # antenna is where it is), so it does not count in the comparison.
    t_settle = min(float(arrival.min()), ts[-1])
    blocks = iter(_blocks(n))
    m = next(blocks)[1]
    err = err_cols(0, m, np.arange(k))
    # Per candidate, fixed over the blocks: its arrival, whether it arrives within the
    # horizon, and the end of its slew plus a step.
    arrival_col = arrival[:, None]
    arrives = arrival <= ts[-1]
    slew_end = arrival + step_s
    while True:
        # The loop commands again once the antenna, settled on its aim point, is more than
        # the deadband off the path; a candidate that cannot arrive inside the horizon holds
        # nothing.
        leaves = (ts[None, :m] >= arrival_col) & (err > deadband_deg)
        next_idx = np.argmax(leaves, axis=1)
        left = leaves.any(axis=1)
        next_idx[~left] = n - 1
        hold = np.where(arrives, ts[next_idx] - t0_s, 0.0)
        window_end = np.maximum(t0_s + np.maximum(hold, min_window_s), t_settle)
        if m == n:
            break
        done = left & (ts[m] >= window_end - 1e-9) & (ts[m] > slew_end)
        if done.all():
            break
        # A done candidate's later errors are out of its window (they count 0 in its peak)
        # and after the sample it left at.
        i0, m = next(blocks)
        block = np.zeros((k, m - i0))
        rows = np.flatnonzero(~done)
        block[rows] = err_cols(i0, m, rows)
        err = np.concatenate([err, block], axis=1)
    # The sample where the error leaves the deadband ends the hold and is the next
    # command's, not this one's, unless it comes on arrival: then this aim never held.
    tm = ts[None, :m]
    in_window = (tm >= t_settle) & (
        (tm < window_end[:, None] - 1e-9) | (tm <= slew_end[:, None]))
    return hold, np.max(np.where(in_window, err, 0.0), axis=1)


def gpredict_aim(path: MountPath, t0_s: float, threshold_deg: float, cycle_s: float,
                 quantise: Callable[[float, float], tuple[float, float]] | None = None
                 ) -> tuple[float, float]:
    """Gpredict's lead (its gtk-rot-ctrl.c): the furthest future path point whose az and el are each
    within ``threshold_deg`` of the current target, found by bisection down to ``cycle/4``.

    Slew time is ignored, as in Gpredict; returns mechanical ``(az, el)``.
    """
    az0, el0 = _at(path, t0_s)
    lo, hi = 0.0, max(0.0, path.end_s - t0_s)
    # Gpredict bisects on the time delta; the path may come back within the threshold
    # later (it is not monotone), so this is the same heuristic, not a global search.
    while hi - lo > cycle_s / 4.0:
        mid = 0.5 * (lo + hi)
        az, el = _at(path, t0_s + mid)
        if abs(az - az0) <= threshold_deg and abs(el - el0) <= threshold_deg:
            lo = mid
        else:
            hi = mid
    az_end, el_end = _at(path, t0_s + lo)
    aim = float(az_end), float(el_end)
    if quantise is not None:
        aim = quantise(*aim)
    return float(aim[0]), float(aim[1])
