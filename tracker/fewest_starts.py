"""The whole-pass command schedule with the fewest motor starts (a dynamic programme, numpy).

Both axes are planned together, exactly, over a class of schedules the motor model
(:class:`tracker.mount.AxisMotor`) carries out as planned (:func:`tracker.schedule.plan_schedule`
turns the result into the commands the live loop sends and checks them):

* every command goes out on a cycle instant, to an axis at rest, with a target on the axis's
  grid (multiples of its resolution, about a degree apart: whole degrees on a GS-232); after
  the start delay the axis turns at its rate and stops on the target (one start);
* the great-circle error to the real target (:meth:`tracker.geometry.MountPath.error_deg`)
  is within the band at every half-cycle sample, less half the target's travel to the next
  or previous sample, so an antenna at rest stays within the band between samples too.

An axis is, at each sample, at rest on a grid point (or where it started), or on its way
from a start position since a known command (its position follows exactly; the target is
decided when it stops, and that target is the one command of the move). Each axis's states
and moves between samples form a graph of their own, built for the whole pass at once
(:class:`_AxisGraph`), with only positions within the band's reach of the target on the
path's branch (in azimuth at most :data:`AZ_REACH_CAP_DEG` either side, so it stays small near
the zenith). The programme keeps, for each pair of axis states that keeps the band, the fewest
starts that reach it; a sample's step is taken one axis at a time (a move of one axis does
not change the other's choices). The answer is therefore the least number of starts within
that class, found exactly; it is not a bound over every schedule (:mod:`tracker.startbound`
is): a move whose target changes on the way, a reversal, or a command to a moving axis are
outside the class.

The result is driven through the motor model and checked against the real target before it is
returned, so a schedule that is returned keeps the band as the model predicts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracker import compiled
from tracker.geometry import MountPath, az_extent_deg
from tracker.mount import AxisMotor

# The azimuth positions searched reach at most this far either side of the target's own.
AZ_REACH_CAP_DEG = 15.0
# No schedule is planned over more samples than this (half-cycle samples: 2 h at 0.5 s).
MAX_SAMPLES = 14_400
# Costs are small integers: float32 holds them exactly.
_INF = np.float32(np.inf)


@dataclass(frozen=True)
class _Axis:
    """One axis's motion: rate, start delay and limits."""

    rate_deg_s: float
    start_delay_s: float
    lo_deg: float
    hi_deg: float
    grid_deg: float

    @classmethod
    def of(cls, axis: AxisMotor) -> _Axis:
        """An axis rests on multiples of its resolution, searched about a degree apart (a
        finer grid would multiply the states for a few per cent fewer starts)."""
        res = axis.resolution_deg
        return cls(axis.rate_deg_s, axis.start_delay_s, axis.min_deg, axis.max_deg,
                   res * max(1, round(1.0 / res)))

    def travel(self, t_from_cmd_s: np.ndarray) -> np.ndarray:
        """How far a move has gone ``t_from_cmd_s`` after its command (not yet arrived)."""
        return self.rate_deg_s * np.maximum(t_from_cmd_s - self.start_delay_s, 0.0)


def _lookup(keys: np.ndarray, want: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of ``want`` in the sorted ``keys`` and whether each is there."""
    at = np.minimum(np.searchsorted(keys, want), max(len(keys) - 1, 0))
    found = keys[at] == want if len(keys) else np.zeros(len(want), dtype=bool)
    return at, found


def _rest_key(sample: np.ndarray, x_deg: np.ndarray) -> np.ndarray:
    return sample.astype(np.int64) * (1 << 32) + np.round((x_deg + 2048.0) * 1000.0).astype(
        np.int64)


class _AxisGraph:
    """One axis over the whole span: per sample its states (at rest on a position, or moving
    since a command: ``chain`` >= 0), each state's position, and the edges into each sample's
    states from the sample before (a rest kept, a move started (one start), a move going on,
    a move stopping on a grid point it passed). States are numbered per sample, rests first;
    a state with no edge into it gets one from a virtual source numbered past the sample's
    states (the programme gives it no finite cost)."""

    def __init__(self, ax: _Axis, ts: np.ndarray, box: tuple[np.ndarray, np.ndarray],
                 starts_deg: np.ndarray, here_deg: float):
        n = len(ts)
        lo = np.maximum(box[0], ax.lo_deg - 1e-9)
        hi = np.minimum(box[1], ax.hi_deg + 1e-9)
        # Rests: the start positions at sample 0; afterwards every grid point in the box,
        # and where the axis is now (it may rest off the grid) while that is in the box.
        g = ax.grid_deg
        q0, q1 = np.ceil(lo[1:] / g - 1e-9).astype(int), np.floor(hi[1:] / g + 1e-9).astype(int)
        count = np.maximum(q1 - q0 + 1, 0)
        r_samp = np.concatenate(([0] * len(starts_deg), np.repeat(np.arange(1, n), count)))
        r_x = np.concatenate((starts_deg, g * (np.repeat(q0, count) + np.arange(count.sum())
                                               - np.repeat(np.cumsum(count) - count, count))))
        on = (here_deg >= lo[1:]) & (here_deg <= hi[1:]) & (np.abs(here_deg / g - np.round(
            here_deg / g)) > 1e-9)
        r_samp = np.concatenate((r_samp, np.flatnonzero(on) + 1))
        r_x = np.concatenate((r_x, np.full(int(on.sum()), here_deg)))
        order = np.lexsort((r_x, r_samp))
        r_samp, r_x = r_samp[order], r_x[order]
        r_key = _rest_key(r_samp, r_x)
        # Moves: from each rest on a cycle instant, either way, followed while in the box.
        birth = (r_samp % 2 == 0) & (r_samp < n - 1)
        b_samp = np.repeat(r_samp[birth], 2)
        b_p0 = np.repeat(r_x[birth], 2)
        b_dir = np.tile([1.0, -1.0], int(birth.sum()))
        c_samp, c_id, c_x, c_next = [], [], [], []
        alive = np.arange(len(b_samp))
        k = 1
        while len(alive):
            s = b_samp[alive] + k
            ok = s < n
            alive, s = alive[ok], s[ok]
            x = b_p0[alive] + b_dir[alive] * ax.travel(ts[s] - ts[b_samp[alive]])
            inside = (x >= lo[s]) & (x <= hi[s])
            alive, s, x = alive[inside], s[inside], x[inside]
            nxt = np.minimum(s + 1, n - 1)
            c_samp.append(s)
            c_id.append(alive)
            c_x.append(x)
            c_next.append(b_p0[alive] + b_dir[alive] * ax.travel(ts[nxt] - ts[b_samp[alive]]))
            k += 1
        m_samp = np.concatenate(c_samp) if c_samp else np.zeros(0, int)
        m_id = np.concatenate(c_id) if c_id else np.zeros(0, int)
        m_x = np.concatenate(c_x) if c_x else np.zeros(0)
        m_next = np.concatenate(c_next) if c_next else np.zeros(0)
        order = np.lexsort((m_id, m_samp))
        m_samp, m_id, m_x, m_next = m_samp[order], m_id[order], m_x[order], m_next[order]
        m_key = m_samp.astype(np.int64) * (1 << 32) + m_id
        # Per sample: rests then moves.
        n_rest = np.bincount(r_samp, minlength=n)
        n_move = np.bincount(m_samp, minlength=n)
        self.off = np.concatenate(([0], np.cumsum(n_rest + n_move)))
        r_local = np.arange(len(r_samp)) - np.repeat(np.cumsum(n_rest) - n_rest, n_rest)
        m_local = (np.arange(len(m_samp)) - np.repeat(np.cumsum(n_move) - n_move, n_move)
                   + n_rest[m_samp])
        self.x = np.empty(self.off[-1])
        self.chain = np.full(self.off[-1], -1)
        self.x[self.off[r_samp] + r_local] = r_x
        self.x[self.off[m_samp] + m_local] = m_x
        self.chain[self.off[m_samp] + m_local] = m_id
        self.b_samp, self.b_dir, self.grid_deg = b_samp, b_dir, g
        # Edges (into sample s + 1, indices local): dst, src, starts.
        dst, src, cost, samp = [], [], [], []

        def add(d_samp, d_local, s_local, starts):
            samp.append(d_samp)
            dst.append(d_local)
            src.append(s_local)
            cost.append(np.full(len(d_samp), starts, dtype=np.float32))

        later = r_samp > 0
        at, found = _lookup(r_key, _rest_key(r_samp[later] - 1, r_x[later]))
        add(r_samp[later][found], r_local[later][found], r_local[at[found]], 0)
        born = b_samp[m_id] == m_samp - 1
        at, found = _lookup(r_key, _rest_key(m_samp[born] - 1, b_p0[m_id[born]]))
        add(m_samp[born][found], m_local[born][found], r_local[at[found]], 1)
        on = ~born
        at, found = _lookup(m_key, m_key[on] - (1 << 32))
        add(m_samp[on][found], m_local[on][found], m_local[at[found]], 0)
        # Stops: grid points strictly past the position now, not past the next one.
        go = m_samp < n - 1
        up = b_dir[m_id[go]] > 0
        xg, ng = m_x[go] / g, m_next[go] / g
        first = np.where(up, np.floor(xg + 1e-9) + 1.0, np.ceil(ng - 1e-9))
        last = np.where(up, np.floor(ng + 1e-9), np.ceil(xg - 1e-9) - 1.0)
        cnt = np.maximum(last - first + 1.0, 0.0).astype(int)
        q = g * (np.repeat(first, cnt) + (np.arange(cnt.sum())
                                          - np.repeat(np.cumsum(cnt) - cnt, cnt)))
        s_from = np.repeat(m_samp[go], cnt)
        at, found = _lookup(r_key, _rest_key(s_from + 1, q))
        add(s_from[found] + 1, r_local[at[found]], np.repeat(m_local[go], cnt)[found], 0)
        samp_a, dst_a = np.concatenate(samp), np.concatenate(dst)
        src_a, cost_a = np.concatenate(src), np.concatenate(cost)
        # States nobody reaches: one edge from the virtual source.
        size = n_rest + n_move
        g_dst = self.off[samp_a] + dst_a
        reached = np.zeros(self.off[-1], dtype=bool)
        reached[g_dst] = True
        lone = np.flatnonzero(~reached[self.off[1]:]) + self.off[1]
        lone_samp = np.searchsorted(self.off, lone, side="right") - 1
        samp_a = np.concatenate((samp_a, lone_samp))
        dst_a = np.concatenate((dst_a, lone - self.off[lone_samp]))
        src_a = np.concatenate((src_a, size[lone_samp - 1]))
        cost_a = np.concatenate((cost_a, np.zeros(len(lone), np.float32)))
        order = np.lexsort((dst_a, samp_a))
        self.e_samp, self.e_dst = samp_a[order], dst_a[order]
        self.e_src, self.e_cost = src_a[order], cost_a[order]
        self.e_off = np.searchsorted(self.e_samp, np.arange(n + 1))
        # Each state's first edge, per sample (reduceat's groups).
        new = np.concatenate((np.ones(min(len(self.e_dst), 1), dtype=bool),
                              (self.e_dst[1:] != self.e_dst[:-1])
                              | (self.e_samp[1:] != self.e_samp[:-1])))
        self.e_first = np.flatnonzero(new) - self.e_off[self.e_samp[new]]
        self.f_off = np.searchsorted(self.e_samp[new], np.arange(n + 1))
        self.size = size
        # Each state's edges, as one range of the edge arrays (states of sample 0 have none).
        self.edge_at = np.concatenate((np.zeros(int(size[0]), np.int64),
                                       np.repeat(self.e_off[1:-1], size[1:])
                                       + self.e_first, [len(self.e_src)])).astype(np.int64)
        # A sample with no state in reach: no schedule of the class can pass it.
        self.blocked = bool((size[1:] == 0).any())
        self._trig: tuple[np.ndarray, np.ndarray] | None = None

    def positions(self, s: int) -> np.ndarray:
        return self.x[self.off[s]:self.off[s + 1]]

    def trig(self, offset_deg: float) -> tuple[np.ndarray, np.ndarray]:
        """(sin, cos) of every state's position plus ``offset_deg`` (the same offset on
        every call)."""
        if self._trig is None:
            r = np.radians(self.x + offset_deg)
            self._trig = (np.sin(r), np.cos(r))
        return self._trig

    def edges(self, s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Into sample s: (source, starts, index of each state's first edge)."""
        a, b = self.e_off[s], self.e_off[s + 1]
        return self.e_src[a:b], self.e_cost[a:b], self.e_first[self.f_off[s]:self.f_off[s + 1]]

    def into(self, s: int, k: int) -> list[tuple[int, float]]:
        """(source, starts) of every edge into state ``k`` of sample ``s``."""
        a, b = self.e_off[s], self.e_off[s + 1]
        lo = a + int(np.searchsorted(self.e_dst[a:b], k))
        hi = a + int(np.searchsorted(self.e_dst[a:b], k, side="right"))
        return list(zip(self.e_src[lo:hi].tolist(), self.e_cost[lo:hi].tolist(), strict=True))

    def moving(self, s: int, k: int) -> bool:
        return bool(self.chain[self.off[s] + k] >= 0)

    def beyond(self, s: int, k: int) -> float:
        """The target of a move still running in state ``k``: the next grid point ahead."""
        x, g = float(self.x[self.off[s] + k]) / self.grid_deg, self.grid_deg
        up = self.b_dir[self.chain[self.off[s] + k]] > 0
        return g * (math.floor(x + 1e-9) + 1.0) if up else g * (math.ceil(x - 1e-9) - 1.0)


def _feasible(ga: _AxisGraph, ge: _AxisGraph, s: int, stop_bearing_deg: float,
              target: np.ndarray, min_dot: float) -> np.ndarray:
    """(n_az, n_el) at sample ``s``: each pair's boresight within the band of ``target`` (a
    unit vector)."""
    sin_b, cos_b = (t[ga.off[s]:ga.off[s + 1]] for t in ga.trig(stop_bearing_deg))
    sin_e, cos_e = (t[ge.off[s]:ge.off[s + 1]] for t in ge.trig(0.0))
    along = sin_b * target[0] + cos_b * target[1]
    return np.multiply.outer(along, cos_e) >= min_dot - sin_e * target[2]


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
    ``t0_s``) on. With ``free_start`` each axis may instead begin at rest on any grid point
    searched at ``t0_s``, for one start (a pre-position move made before). None when no
    schedule of the class keeps the band (or the span is longer than :data:`MAX_SAMPLES`)."""
    return StartsProgramme(path, az_axis, el_axis, t0_s, end_s, band_deg, cycle_s,
                           free_start).solve(band_deg, from_s)


class StartsProgramme:
    """The programme of :func:`fewest_starts` over one span, for any band up to
    ``reach_deg``: the axes' graphs (the costly part) are built once, for the positions
    within ``reach_deg`` of the target, and :meth:`solve` runs the programme for a band."""

    def __init__(self, path: MountPath, az_axis: AxisMotor, el_axis: AxisMotor, t0_s: float,
                 end_s: float, reach_deg: float, cycle_s: float = 0.5,
                 free_start: bool = False):
        self.path, self.t0_s, self.reach_deg = path, t0_s, reach_deg
        self.ts = ts = np.arange(t0_s, min(end_s, path.end_s) + 1e-9, 0.5 * cycle_s)
        self.graphs: tuple[_AxisGraph, _AxisGraph] | None = None
        if (len(ts) < 2 or len(ts) > MAX_SAMPLES or az_axis.moving(t0_s)
                or el_axis.moving(t0_s)):
            return
        self.target = target = path.target_enu(ts)
        boxes = _boxes(path, ts, target, reach_deg)
        graphs, costs = [], []
        for k, axis in enumerate((az_axis, el_axis)):
            ax = _Axis.of(axis)
            here = float(axis.position(t0_s))
            starts = np.array([here])
            if free_start:
                lo, hi = max(boxes[k][0][0], ax.lo_deg), min(boxes[k][1][0], ax.hi_deg)
                g = ax.grid_deg
                whole = g * np.arange(math.ceil(lo / g - 1e-9), math.floor(hi / g + 1e-9) + 1)
                starts = np.concatenate((starts, whole[np.abs(whole - here) > 1e-9]))
            graphs.append(_AxisGraph(ax, ts, boxes[k], starts, here))
            # Start positions sort with ``here`` among them: each away from it cost a start.
            costs.append(np.where(np.abs(graphs[k].positions(0) - here) > 1e-9, 1.0, 0.0
                                  ).astype(np.float32))
        if graphs[0].blocked or graphs[1].blocked:
            return
        self.graphs = graphs[0], graphs[1]
        self.v0 = costs[0][:, None] + costs[1][None, :]
        # Between samples the target moves on: an antenna at rest within band - (half its
        # travel to the neighbouring samples) at a sample stays within the band until the
        # next one.
        step = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", target[1:], target[:-1]),
                                            -1.0, 1.0)))
        self.travel = np.maximum(np.concatenate((step, [0.0])), np.concatenate(([0.0], step)))

    def solve(self, band_deg: float, from_s: float | None = None) -> FewestStarts | None:
        """The schedule keeping ``band_deg`` (at most the reach) from ``from_s`` (default the
        span's start) on, as :func:`fewest_starts`."""
        if self.graphs is None:
            return None
        if band_deg > self.reach_deg + 1e-9:
            raise ValueError(f"a band of {band_deg} deg is beyond the {self.reach_deg} deg "
                             f"searched")
        ga, ge = self.graphs
        min_dot = np.cos(np.radians(np.maximum(band_deg - 0.5 * self.travel, 0.0)))
        checked = self.ts >= (self.t0_s if from_s is None else from_s) - 1e-9
        v0 = self.v0.copy()
        stop, target = self.path.stop_bearing_deg, self.target
        if checked[0]:
            v0[~_feasible(ga, ge, 0, stop, target[0], float(min_dot[0]))] = _INF
        run = _programme_compiled if compiled.backend() == "numba" else _programme
        found = run(ga, ge, v0, stop, target, min_dot, checked)
        return None if found is None else _schedule(*found, ga, ge, self.ts)


_Found = tuple[np.ndarray, np.ndarray, int]


def _programme(ga: _AxisGraph, ge: _AxisGraph, v0: np.ndarray, stop_bearing_deg: float,
               target: np.ndarray, min_dot: np.ndarray, checked: np.ndarray) -> _Found | None:
    """The programme in numpy: the least-cost state pair of each sample on one least-cost
    path (az states, el states, its starts), or None when no pair keeps the band at some
    sample. Its twin :func:`_programme_compiled` takes the same steps."""
    n = len(target)
    v = v0
    values = [v]
    for s in range(1, n):
        # One more row and column of no finite cost: the virtual source of both axes.
        padded = np.full((v.shape[0] + 1, v.shape[1] + 1), _INF, np.float32)
        padded[:-1, :-1] = v
        src, cost, first = ga.edges(s)
        mid = np.minimum.reduceat(padded[src] + cost[:, None], first, axis=0)
        src, cost, first = ge.edges(s)
        v = np.minimum.reduceat(mid[:, src] + cost, first, axis=1)
        if checked[s]:
            v[~_feasible(ga, ge, s, stop_bearing_deg, target[s], float(min_dot[s]))] = _INF
        values.append(v)
        if s % 32 == 0 and not np.isfinite(v).any():
            return None
    if not np.isfinite(v).any():
        return None
    # Back from the first least-cost pair of the last sample, through the first of each
    # pair's least-cost predecessors (in edge order).
    a, e = (int(i) for i in np.unravel_index(int(np.argmin(v)), v.shape))
    total = int(v[a, e])
    ka, ke = np.zeros(n, np.int64), np.zeros(n, np.int64)
    ka[-1], ke[-1] = a, e
    for s in range(n - 1, 0, -1):
        want, before = float(values[s][a, e]), values[s - 1]
        pair = next(((pa, pe) for pa, ca in ga.into(s, a) if pa < before.shape[0]
                     for pe, ce in ge.into(s, e)
                     if pe < before.shape[1] and float(before[pa, pe]) + ca + ce == want), None)
        assert pair is not None, "a least-cost state has a predecessor of that cost"
        a, e = ka[s - 1], ke[s - 1] = pair
    return ka, ke, total


# Costs of the compiled programme: int16, with this for "no finite cost" (a start or two
# added to it still fits, and min() keeps it: no branch in the inner loops).
_NONE16 = 16_000


def _programme_compiled(ga: _AxisGraph, ge: _AxisGraph, v0: np.ndarray,
                        stop_bearing_deg: float, target: np.ndarray, min_dot: np.ndarray,
                        checked: np.ndarray) -> _Found | None:
    """:func:`_programme` as compiled loops (:data:`_loops`), with the same result."""
    n = len(target)
    v_off = np.concatenate(([0], np.cumsum(ga.size.astype(np.int64) * ge.size)))
    values = np.empty(int(v_off[-1]), np.int16)
    values[:v_off[1]] = np.where(np.isfinite(v0), v0, _NONE16).ravel()
    mid = np.empty(int((ga.size[1:] * ge.size[:-1]).max()), np.int16)
    sin_b, cos_b = ga.trig(stop_bearing_deg)
    sin_e, cos_e = ge.trig(0.0)
    edges = (ga.off, ga.edge_at, ga.e_src, ga.e_cost.astype(np.int16),
             ge.off, ge.edge_at, ge.e_src, ge.e_cost.astype(np.int16))
    reached = _loops("_forward_loop")(*edges, sin_b, cos_b, sin_e, cos_e, target, min_dot,
                                      checked, v_off, values, mid)
    if reached < n:
        return None
    last = values[v_off[-2]:]
    best = int(np.argmin(last))
    if last[best] == _NONE16:
        return None
    ka, ke = np.zeros(n, np.int64), np.zeros(n, np.int64)
    ka[-1], ke[-1] = divmod(best, int(ge.size[-1]))
    _loops("_path_loop")(*edges, v_off, values, ka, ke)
    return ka, ke, int(last[best])


def _forward_loop(a_off, a_edge, a_src, a_cost, e_off, e_edge, e_src, e_cost, sin_b, cos_b,
                  sin_e, cos_e, target, min_dot, checked, v_off, values, mid
                  ):  # pragma: no cover - compiled by numba (its twin: _programme)
    """Fills ``values`` (each sample's az x el costs, flat) from sample 0's; returns the first
    sample with no finite cost (len(target) when there is none)."""
    n = len(target)
    for s in range(1, n):
        pe = e_off[s] - e_off[s - 1]
        _az_step(a_off[s], a_off[s + 1] - a_off[s], a_off[s] - a_off[s - 1], pe, a_edge, a_src,
                 a_cost, values, v_off[s - 1], mid)
        if not _el_step(a_off[s], a_off[s + 1] - a_off[s], e_off[s], e_off[s + 1] - e_off[s],
                        pe, e_edge, e_src, e_cost, sin_b, cos_b, sin_e, cos_e, target[s],
                        min_dot[s], checked[s], mid, values, v_off[s]):
            return s
    return n


def _az_step(a0, na, pa, pe, a_edge, a_src, a_cost, values, before, mid
             ):  # pragma: no cover - compiled by numba (in _forward_loop)
    """mid[i, j]: the least cost of az state i with el state j of the sample before (at or
    above :data:`_NONE16`: none)."""
    for i in range(na):
        row = i * pe
        mid[row:row + pe] = _NONE16
        for k in range(a_edge[a0 + i], a_edge[a0 + i + 1]):
            src = a_src[k]
            if src >= pa:  # the virtual source
                continue
            c, base = a_cost[k], before + src * pe
            for j in range(pe):
                x = values[base + j] + c
                if x < mid[row + j]:
                    mid[row + j] = x


def _el_step(a0, na, e0, ne, pe, e_edge, e_src, e_cost, sin_b, cos_b, sin_e, cos_e, target,
             min_dot, checked, mid, values, now
             ) -> bool:  # pragma: no cover - compiled by numba (in _forward_loop)
    """The sample's costs from ``mid``, and the band (as :func:`_feasible`); whether any is
    finite."""
    none = _NONE16
    alive = False
    for i in range(na):
        along = sin_b[a0 + i] * target[0] + cos_b[a0 + i] * target[1]
        row = i * pe
        for j in range(ne):
            best = none
            for k in range(e_edge[e0 + j], e_edge[e0 + j + 1]):
                src = e_src[k]
                if src < pe:
                    best = min(best, mid[row + src] + e_cost[k])
            if checked and not (along * cos_e[e0 + j] >= min_dot - sin_e[e0 + j] * target[2]):
                best = none
            values[now + i * ne + j] = best
            alive = alive or best < none
    return alive


def _path_loop(a_off, a_edge, a_src, a_cost, e_off, e_edge, e_src, e_cost, v_off, values, ka,
               ke):  # pragma: no cover - compiled by numba (its twin: _programme's last loop)
    """Back from the pair in ``ka[-1], ke[-1]``: the first least-cost predecessor pair of each
    sample's, in edge order, into ``ka``, ``ke``."""
    for s in range(len(ka) - 1, 0, -1):
        a, e = ka[s], ke[s]
        pa, pe, ne = a_off[s] - a_off[s - 1], e_off[s] - e_off[s - 1], e_off[s + 1] - e_off[s]
        want = values[v_off[s] + a * ne + e]
        for k1 in range(a_edge[a_off[s] + a], a_edge[a_off[s] + a + 1]):
            if a_src[k1] >= pa:
                continue
            for k2 in range(e_edge[e_off[s] + e], e_edge[e_off[s] + e + 1]):
                if e_src[k2] >= pe:
                    continue
                x = values[v_off[s - 1] + a_src[k1] * pe + e_src[k2]]
                if x < _NONE16 and x + a_cost[k1] + e_cost[k2] == want:
                    ka[s - 1], ke[s - 1] = a_src[k1], e_src[k2]
                    break
            else:
                continue
            break


_loops = compiled.Loops(globals(), helpers=("_az_step", "_el_step"))


def _boxes(path: MountPath, ts: np.ndarray, target: np.ndarray, band_deg: float
           ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Per sample the azimuth and elevation ranges searched: around the path and the target's
    position on the path's branch (its mechanical az nearest the path's, over the top where
    the path is), widened by the band's reach (az at most :data:`AZ_REACH_CAP_DEG`). The two
    coincide on an exact path; a keyhole path holds its azimuth while the target's swings
    round near the zenith, and there only the path's range is searched."""
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
    near = np.abs(centre_az - path_az) <= AZ_REACH_CAP_DEG
    az_lo = np.where(near, np.minimum(centre_az, path_az), path_az) - w_az
    az_hi = np.where(near, np.maximum(centre_az, path_az), path_az) + w_az
    return ((az_lo, az_hi),
            (np.minimum(centre_el, path_el) - w_el, np.maximum(centre_el, path_el) + w_el))


def _schedule(ka: np.ndarray, ke: np.ndarray, total: int, ga: _AxisGraph, ge: _AxisGraph,
              ts: np.ndarray) -> FewestStarts:
    """The commands of the path through the states ``ka`` (az) and ``ke`` (el), one per
    sample: each move's command goes out the sample before the axis is first seen moving,
    with the target it stops on (a move still running at the end goes on to the next grid
    point beyond its last position: the schedule says nothing after it)."""
    n = len(ts)
    moves: dict[int, list[float | None]] = {}
    for k_axis, (g, k) in enumerate(((ga, ka), (ge, ke))):
        state = g.off[:-1] + k
        moving, x = g.chain[state] >= 0, g.x[state]
        begins = np.flatnonzero(moving[1:] & ~moving[:-1]) + 1
        stops = np.flatnonzero(~moving[1:] & moving[:-1]) + 1
        ends = np.append(x[stops], g.beyond(n - 1, int(k[-1])) if moving[-1] else np.nan)
        for s, end in zip(begins.tolist(), ends[np.searchsorted(stops, begins)].tolist(),
                          strict=True):
            moves.setdefault(s - 1, [None, None])[k_axis] = end
    out = tuple((float(ts[i]), m[0], m[1]) for i, m in sorted(moves.items()))
    return FewestStarts(out, total, float(ga.positions(0)[ka[0]]),
                        float(ge.positions(0)[ke[0]]))
