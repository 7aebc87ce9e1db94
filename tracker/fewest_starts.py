"""The whole-pass command schedule with the fewest motor starts (a dynamic programme, numpy).

:func:`tracker.schedule.plan_schedule` splits the deadband between the axes and plans each
greedily. Here both axes are planned together, exactly, over a class of schedules the motor
model (:class:`tracker.mount.AxisMotor`) carries out as planned:

* every command goes out on a cycle instant, to a whole-degree target, to an axis at rest;
  after the start delay the axis turns at its rate and stops on the target (one start);
* the great-circle error to the real target (:meth:`tracker.geometry.MountPath.error_deg`)
  is within the band at every half-cycle sample, the grid the streaming benchmark measures on.

An axis is, at each sample, at rest on a whole degree (or where it started), or on its way
from a start position since a known command (its position follows exactly; the target is
decided when it stops, and that target is the one command of the move). The programme keeps,
for each pair of axis states that keeps the band, the fewest starts that reach it; the pair
space is searched one axis at a time (a move of one axis does not change the other's
choices), and only positions within the band's reach of the target on the path's branch are
kept (in azimuth at most :data:`AZ_REACH_CAP_DEG` either side, so the search stays small near
the zenith). The answer is therefore the least number of starts within that class, found
exactly; it is not a bound over every schedule (:mod:`tracker.startbound` is): a move whose
target changes on the way, a reversal, or a command to a moving axis are outside the class.

The result is driven through the motor model and checked against the real target before it is
returned, so a schedule that is returned keeps the band as the model predicts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracker.geometry import MountPath, az_extent_deg
from tracker.mount import AxisMotor

# The azimuth positions searched reach at most this far either side of the target's own.
AZ_REACH_CAP_DEG = 15.0
# No schedule is planned over more samples than this (half-cycle samples: 2 h at 0.5 s).
MAX_SAMPLES = 14_400
# Costs are small integers: float32 holds them exactly.
_INF = np.float32(np.inf)
_REST, _UP, _DOWN = 0, 1, -1


@dataclass(frozen=True)
class _Axis:
    """One axis's motion: rate, start delay, limits, and the sample grid."""

    rate_deg_s: float
    start_delay_s: float
    lo_deg: float
    hi_deg: float

    def position(self, p0: np.ndarray, kind: np.ndarray, t_cmd_s: np.ndarray,
                 t_s: float) -> np.ndarray:
        """Where a moving state is at ``t_s``: ``p0`` plus the travel since its onset (the
        target is not applied: a state that is still moving has not reached it)."""
        return p0 + kind * self.rate_deg_s * np.maximum(t_s - t_cmd_s - self.start_delay_s,
                                                        0.0)


@dataclass
class _States:
    """One axis's states at one sample: kind (rest / up / down), start position, command
    sample (-1 at rest) and exact position."""

    kind: np.ndarray
    p0: np.ndarray
    c: np.ndarray
    x: np.ndarray

    def take(self, idx: np.ndarray) -> _States:
        return _States(self.kind[idx], self.p0[idx], self.c[idx], self.x[idx])


def _key(kind: np.ndarray, p0: np.ndarray, c: np.ndarray) -> np.ndarray:
    """One int64 per state (kind, start position to 1e-3 deg, command sample)."""
    p = np.round((p0 + 2048.0) * 1000.0).astype(np.int64)
    return ((c.astype(np.int64) + 1) * (1 << 23) + p) * 3 + (kind.astype(np.int64) + 1)


def _successors(st: _States, ax: _Axis, t_s: np.ndarray, i: int, can_start: bool
                ) -> tuple[_States, np.ndarray, np.ndarray]:
    """Every state at sample i + 1 reachable from ``st`` at sample i: (states, source index,
    starts) per edge."""
    n = len(st.kind)
    idx = np.arange(n)
    rest = st.kind == _REST
    moving = ~rest
    t_next = float(t_s[i + 1])
    parts = []
    # At rest: stays.
    r = idx[rest]
    parts.append((np.zeros(len(r), np.int8), st.p0[r], np.full(len(r), -1), st.x[r], r,
                  np.zeros(len(r), np.int8)))
    if can_start:
        for kind in (_UP, _DOWN):
            c = np.full(len(r), i)
            x = ax.position(st.x[r], np.full(len(r), kind), np.full(len(r), float(t_s[i])),
                            t_next)
            parts.append((np.full(len(r), kind, np.int8), st.x[r], c, x, r,
                          np.ones(len(r), np.int8)))
    m = idx[moving]
    if len(m):
        k = st.kind[m]
        x_next = ax.position(st.p0[m], k.astype(float), t_s[st.c[m]], t_next)
        parts.append((k, st.p0[m], st.c[m], x_next, m, np.zeros(len(m), np.int8)))
        # Stops on a whole degree passed between the samples: strictly beyond the position
        # now, at most the position the axis would reach.
        up = k == _UP
        first = np.where(up, np.floor(st.x[m]) + 1.0, np.ceil(x_next))
        last = np.where(up, np.floor(x_next), np.ceil(st.x[m]) - 1.0)
        count = np.maximum(last - first + 1.0, 0.0).astype(int)
        if count.any():
            src = np.repeat(m, count)
            base = np.repeat(first, count)
            offs = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
            q = base + offs
            parts.append((np.zeros(len(src), np.int8), q, np.full(len(src), -1), q, src,
                          np.zeros(len(src), np.int8)))
    kind, p0, c, x, src, cost = (np.concatenate(col) for col in zip(*parts, strict=True))
    ok = (x >= ax.lo_deg - 1e-9) & (x <= ax.hi_deg + 1e-9)
    return (_States(kind[ok], p0[ok], c[ok], x[ok]), src[ok], cost[ok])


def _merge(st: _States, src: np.ndarray, cost: np.ndarray, box: tuple[float, float]
           ) -> tuple[_States, np.ndarray, np.ndarray, np.ndarray]:
    """The distinct states within ``box``, and the edges into them sorted by state:
    (states, edge source, edge starts, index of each state's first edge)."""
    keep = (st.x >= box[0]) & (st.x <= box[1])
    st, src, cost = st.take(keep), src[keep], cost[keep]
    if len(src) == 0:
        return st, src, cost, src
    keys = _key(st.kind, st.p0, st.c)
    order = np.argsort(keys, kind="stable")
    keys, src, cost = keys[order], src[order], cost[order]
    first = np.flatnonzero(np.concatenate(([True], keys[1:] != keys[:-1])))
    return st.take(order[first]), src, cost, first


def _step(v: np.ndarray, src: np.ndarray, cost: np.ndarray, first: np.ndarray, axis: int
          ) -> np.ndarray:
    """Least cost into each new state of one axis (``axis`` of ``v``), the other axis's
    states unchanged."""
    if axis == 0:
        g = v[src, :] + cost[:, None].astype(np.float32)
    else:
        g = v[:, src] + cost[None, :].astype(np.float32)
    return np.minimum.reduceat(g, first, axis=axis)


def _feasible(az: np.ndarray, el: np.ndarray, stop_bearing_deg: float, target: np.ndarray,
              min_dot: float) -> np.ndarray:
    """(n_az, n_el): each pair's boresight within the band of ``target`` (a unit vector)."""
    b = np.radians(np.mod(az + stop_bearing_deg, 360.0))
    along = np.sin(b) * target[0] + np.cos(b) * target[1]
    e = np.radians(el)
    return np.outer(along, np.cos(e)) + (np.sin(e) * target[2])[None, :] >= min_dot


@dataclass
class _Layer:
    az: _States
    el: _States
    v: np.ndarray


@dataclass(frozen=True)
class FewestStarts:
    """A schedule of :func:`fewest_starts`: ``commands`` ``(t_s, az or None, el or None)``
    (an axis without a target keeps its own), on cycle instants, from the axes at rest on
    ``start_az_deg`` / ``start_el_deg`` at the first sample; ``starts`` counts the motor
    starts of the commands plus, with a free start, one per axis moved there first."""

    commands: tuple[tuple[float, float | None, float | None], ...]
    starts: int
    start_az_deg: float
    start_el_deg: float


def fewest_starts(path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor, t0_s: float,
                  end_s: float, band_deg: float, cycle_s: float = 0.5,
                  from_s: float | None = None, free_start: bool = False
                  ) -> FewestStarts | None:
    """The schedule with the fewest starts in the class of the module doc, from ``t0_s`` (a
    cycle instant, both axes at rest) to ``end_s``, keeping the band from ``from_s`` (default
    ``t0_s``) on. With ``free_start`` each axis may instead begin at rest on any whole degree
    searched at ``t0_s``, for one start (a pre-position move made before). None when no
    schedule of the class keeps the band (or the span is longer than :data:`MAX_SAMPLES`)."""
    dt = 0.5 * cycle_s
    ts = np.arange(t0_s, min(end_s, path.end_s) + 1e-9, dt)
    n = len(ts)
    if n < 2 or n > MAX_SAMPLES or az_axis.moving(t0_s) or el_axis.moving(t0_s):
        return None
    axes = (_Axis(az_axis.rate_deg_s, az_axis.start_delay_s, az_axis.min_deg, az_axis.max_deg),
            _Axis(el_axis.rate_deg_s, el_axis.start_delay_s, el_axis.min_deg, el_axis.max_deg))
    target = path.target_enu(ts)
    boxes = _boxes(path, ts, target, band_deg)
    min_dot = math.cos(math.radians(band_deg))
    checked = ts >= (t0_s if from_s is None else from_s) - 1e-9
    cur, costs = [], []
    for k, axis in enumerate((az_axis, el_axis)):
        here = float(axis.position(t0_s))
        lo, hi = boxes[k][0]
        others = np.arange(max(math.ceil(lo), math.ceil(axes[k].lo_deg)),
                           min(math.floor(hi), math.floor(axes[k].hi_deg)) + 1.0)
        xs = np.concatenate(([here], others[np.abs(others - here) > 1e-9])) if free_start \
            else np.array([here])
        cur.append(_States(np.zeros(len(xs), np.int8), xs, np.full(len(xs), -1), xs))
        costs.append(np.where(np.arange(len(xs)) == 0, 0.0, 1.0).astype(np.float32))
    v = costs[0][:, None] + costs[1][None, :]
    if checked[0]:
        v = np.where(_feasible(cur[0].x, cur[1].x, path.stop_bearing_deg, target[0], min_dot),
                     v, _INF)
        if not np.isfinite(v).any():
            return None
    layers = [_Layer(cur[0], cur[1], v)]
    for i in range(n - 1):
        can_start = i % 2 == 0
        nxt = []
        for a, ax in enumerate(axes):
            st, src, cost = _successors(cur[a], ax, ts, i, can_start)
            merged = _merge(st, src, cost, boxes[a][i + 1])
            if len(merged[0].kind) == 0:
                return None
            v = _step(v, merged[1], merged[2], merged[3], a)
            nxt.append(merged[0])
        if checked[i + 1]:
            ok = _feasible(nxt[0].x, nxt[1].x, path.stop_bearing_deg, target[i + 1], min_dot)
            v = np.where(ok, v, _INF)
        live = np.isfinite(v)
        rows, cols = np.flatnonzero(live.any(axis=1)), np.flatnonzero(live.any(axis=0))
        if len(rows) == 0:
            return None
        cur = [nxt[0].take(rows), nxt[1].take(cols)]
        v = v[np.ix_(rows, cols)]
        layers.append(_Layer(cur[0], cur[1], v))
    return _backtrack(layers, axes, ts)


def _boxes(path: MountPath, ts: np.ndarray, target: np.ndarray, band_deg: float
           ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """Per sample the azimuth and elevation ranges searched: the target's position on the
    path's branch (its mechanical az nearest the path's, over the top where the path is),
    widened by the band's reach (az capped at :data:`AZ_REACH_CAP_DEG`)."""
    path_az, path_el = path.mount_at(ts)
    assert path_el is not None
    el_t = np.degrees(np.arcsin(np.clip(target[:, 2], -1.0, 1.0)))
    bearing_t = np.degrees(np.arctan2(target[:, 0], target[:, 1]))
    over = path_el > 90.0
    looks = path_az + path.stop_bearing_deg + np.where(over, 180.0, 0.0)
    centre_az = path_az + (np.mod(bearing_t - looks + 180.0, 360.0) - 180.0)
    centre_el = np.where(over, 180.0 - el_t, el_t)
    w_az = np.minimum(az_extent_deg(band_deg, el_t), AZ_REACH_CAP_DEG) + 1e-6
    w_el = band_deg + 1e-6
    az = list(zip((centre_az - w_az).tolist(), (centre_az + w_az).tolist(), strict=True))
    el = list(zip((centre_el - w_el).tolist(), (centre_el + w_el).tolist(), strict=True))
    return az, el


def _beyond(st: _States, k: int) -> float | None:
    """The target of a move still running in state ``k``: the next whole degree ahead."""
    kind, x = int(st.kind[k]), float(st.x[k])
    if kind == _REST:
        return None
    return math.floor(x) + 1.0 if kind == _UP else math.ceil(x) - 1.0


def _predecessors(st: _States, k: int, prev: _States, ax: _Axis, ts: np.ndarray, i: int
                  ) -> list[tuple[int, int]]:
    """(index in ``prev`` at sample i, starts) of every edge into state ``k`` at i + 1."""
    kind, p0, c = int(st.kind[k]), float(st.p0[k]), int(st.c[k])
    rest = prev.kind == _REST
    if kind != _REST:
        if c == i:
            hit = np.flatnonzero(rest & (np.abs(prev.x - p0) < 1e-9))
            return [(int(j), 1) for j in hit]
        hit = np.flatnonzero((prev.kind == kind) & (prev.c == c) & (np.abs(prev.p0 - p0) < 1e-9))
        return [(int(j), 0) for j in hit]
    q = float(st.x[k])
    out = [(int(j), 0) for j in np.flatnonzero(rest & (np.abs(prev.x - q) < 1e-9))]
    mv = np.flatnonzero(~rest)
    if len(mv):
        kk = prev.kind[mv].astype(float)
        x_next = ax.position(prev.p0[mv], kk, ts[prev.c[mv]], float(ts[i + 1]))
        passes = (kk * (q - prev.x[mv]) > 1e-9) & (kk * (q - x_next) <= 1e-9)
        out += [(int(j), 0) for j in mv[passes]]
    return out


def _backtrack(layers: list[_Layer], axes: tuple[_Axis, _Axis], ts: np.ndarray
               ) -> FewestStarts:
    """The commands of one least-cost path through ``layers``."""
    last = layers[-1]
    a, e = np.unravel_index(int(np.argmin(last.v)), last.v.shape)
    total = int(last.v[a, e])
    moves: dict[int, list[float | None]] = {}
    # The stop ahead of each axis, going back; a move still running at the end goes on to
    # the next whole degree beyond its last position (the schedule says nothing after it).
    ends = [_beyond(last.az, a), _beyond(last.el, e)]
    for i in range(len(layers) - 2, -1, -1):
        here, prev = layers[i + 1], layers[i]
        want = float(here.v[a, e])
        found = None
        for pa, ca in _predecessors(here.az, a, prev.az, axes[0], ts, i):
            for pe, ce in _predecessors(here.el, e, prev.el, axes[1], ts, i):
                if float(prev.v[pa, pe]) + ca + ce == want:
                    found = (pa, pe)
                    break
            if found:
                break
        assert found is not None, "a least-cost state has a predecessor of that cost"
        for k_axis, (now, before, k, pk) in enumerate(((here.az, prev.az, a, found[0]),
                                                       (here.el, prev.el, e, found[1]))):
            moving_now, moving_before = now.kind[k] != _REST, before.kind[pk] != _REST
            if not moving_now and moving_before:
                ends[k_axis] = float(now.x[k])           # the move that stops here
            elif moving_now and not moving_before:
                moves.setdefault(i, [None, None])[k_axis] = ends[k_axis]
                ends[k_axis] = None
        a, e = found
    out = tuple((float(ts[i]), m[0], m[1]) for i, m in sorted(moves.items()))
    first = layers[0]
    return FewestStarts(out, total, float(first.az.x[a]), float(first.el.x[e]))
