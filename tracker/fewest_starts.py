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
from functools import cached_property

import numpy as np

from tracker import compiled
from tracker.geometry import MountPath, az_extent_deg
from tracker.mount import AxisMotor

# The azimuth positions searched reach at most this far either side of the target's own.
# Near the zenith the target's azimuth can run at twice the motor's rate: there the azimuth
# must fall behind by more than 15 deg (20 deg at el 84 is 2 deg on the sky); a cap of 15
# leaves such passes (UWE-3 culminating at 85.6 deg, in tests/test_schedule.py) with no
# schedule at all.
AZ_REACH_CAP_DEG = 30.0
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


class _Rests:
    """One axis's rests over the span, in state order (by sample, then position): the start
    positions at sample 0; afterwards every grid point in the box, and where the axis is now
    (it may rest off the grid) while that is in the box."""

    def __init__(self, grid_deg: float, lo: np.ndarray, hi: np.ndarray, starts_deg: np.ndarray,
                 here_deg: float):
        n, g = len(lo), grid_deg
        q0, q1 = np.ceil(lo[1:] / g - 1e-9).astype(int), np.floor(hi[1:] / g + 1e-9).astype(int)
        count = np.maximum(q1 - q0 + 1, 0)
        first = np.cumsum(count) - count
        samp = np.repeat(np.arange(1, n), count)
        x = g * (np.repeat(q0, count) + np.arange(count.sum()) - np.repeat(first, count))
        on = (here_deg >= lo[1:]) & (here_deg <= hi[1:]) & (np.abs(here_deg / g - np.round(
            here_deg / g)) > 1e-9)
        self.here_on: np.ndarray | None = None
        self.here_q, self.collide = 0, False
        if on.any():
            # Off the grid, the axis's position sorts after the grid points at or below it.
            self.here_q = _last_at_or_below(g, here_deg)
            at = first[on] + np.clip(self.here_q - q0[on] + 1, 0, count[on])
            samp = np.insert(samp, at, np.flatnonzero(on) + 1)
            x = np.insert(x, at, here_deg)
            self.here_on = np.concatenate(([False], on))
            # Off the grid but within the keys' rounding (to a thousandth of a degree) of a
            # grid point, the position has that point's key: lookups then go by key.
            near = np.array([here_deg, g * round(here_deg / g)])
            self.collide = bool(np.diff(_rest_key(np.zeros(2, np.int64), near))[0] == 0)
        self.samp = np.concatenate((np.zeros(len(starts_deg), np.int64), samp))
        self.x = np.concatenate((np.sort(starts_deg, kind="stable"), x))
        self.key = _rest_key(self.samp, self.x)
        self.count = np.bincount(self.samp, minlength=n)
        self.base = np.cumsum(self.count) - self.count
        self.local = np.arange(len(self.samp)) - self.base[self.samp]
        self.grid_deg = g
        self._q0 = np.concatenate(([0], q0))
        self._n_grid = np.concatenate(([0], count)).astype(np.uint64)

    def grid_at(self, s: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :func:`_lookup` of the rest on grid point ``q`` (whole grid steps) at samples
        ``s`` (after the first): the first rest of that key, and whether there is one (where
        there is none the index is meaningless). Grid points are far more than a key's
        rounding apart, so each has a key of its own unless the axis rests that close to
        it."""
        if self.collide:
            return _lookup(self.key, _rest_key(s, self.grid_deg * q))
        j = q - self._q0[s]
        found = j.view(np.uint64) < self._n_grid[s]  # 0 <= j < the sample's grid points
        at = self.base[s] + j
        if self.here_on is not None:
            at += self.here_on[s] & (q > self.here_q)
        return at, found


def _last_at_or_below(grid_deg: float, x_deg: float) -> int:
    """The greatest q with grid_deg * q <= x_deg, as the grid's positions are computed."""
    q = math.floor(x_deg / grid_deg)
    while grid_deg * (q + 1) <= x_deg:
        q += 1
    while grid_deg * q > x_deg:
        q -= 1
    return q


class _Block:
    """The moving states some steps after their command (a block a step), in chain order:
    sample, chain, position; ``before``: each one's index in the block of the step before.
    ``shift``: per sample, where the block's states there begin in the block, plus the
    moving states there of this block and of the blocks of earlier steps (those come last in
    the sample: chain order puts an earlier command first), so a state's index in its sample
    is its index in the block + size - shift. ``stop_from``, ``stop_to``: the stops at the
    next sample (index in this block, rest stopped on). ``at``, ``local``: each state's
    index overall and in its sample."""

    def __init__(self, s: np.ndarray, chain: np.ndarray, x: np.ndarray, before: np.ndarray,
                 shift: np.ndarray):
        self.s, self.chain, self.x, self.before, self.shift = s, chain, x, before, shift
        self.stop_from = self.stop_to = self.at = self.local = np.zeros(0, np.int64)


def _follow(ax: _Axis, ts: np.ndarray, lo: np.ndarray, hi: np.ndarray, b_samp: np.ndarray,
            b_p0: np.ndarray, b_dir: np.ndarray, rests: _Rests
            ) -> tuple[list[_Block], np.ndarray]:
    """The moves from each birth, followed while in the box: their blocks, one a step, and
    the moving states at each sample."""
    n, g = len(ts), ax.grid_deg
    chain, s, p0, dr = np.arange(len(b_samp)), b_samp, b_p0, b_dir
    f_before: np.ndarray = np.zeros(0)
    placed = np.zeros(n, np.int64)
    travel = np.zeros(n)  # per sample, of a move commanded k samples before
    blocks: list[_Block] = []
    k = 1
    while len(chain):
        s = s + 1
        ok = int(np.searchsorted(s, n))  # chains in order of their commands: s ascending
        if not ok:
            break
        if ok < len(s):
            chain, p0, dr, s = chain[:ok], p0[:ok], dr[:ok], s[:ok]
        travel[k:] = ax.travel(ts[k:] - ts[:n - k])
        x = p0 + dr * travel[s]
        # The last grid point reached, in grid steps along the move (dr * q).
        f = np.floor(dr * (x / g) + 1e-9)
        if blocks:
            blocks[-1].stop_from, blocks[-1].stop_to = _stops(rests, s, f, f_before[:ok], dr)
        keep = np.flatnonzero((x >= lo[s]) & (x <= hi[s]))
        chain, p0, dr, s, x, f = (a[keep] for a in (chain, p0, dr, s, x, f))
        count = np.bincount(s, minlength=n)
        placed += count
        blocks.append(_Block(s, chain, x, keep, np.cumsum(count) - count + placed))
        f_before = f
        k += 1
    return blocks, placed


def _stops(rests: _Rests, s: np.ndarray, f_next: np.ndarray, f_now: np.ndarray,
           dr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stops at samples ``s`` of moves at the sample before (``f_now``, ``f_next`` of
    :func:`_follow`, direction ``dr``): on grid points strictly past the position then, not
    past the one now (f_now < dr * q <= f_next). Each stop's (move, rest)."""
    passed = f_next - f_now
    sel = np.flatnonzero(passed > 0)
    along, step = f_now[sel] + 1.0, dr[sel]
    s = s[sel]
    moves, to = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    while len(sel):
        at, found = rests.grid_at(s, (step * along).astype(np.int64))
        moves.append(sel[found])
        to.append(at[found])
        more = np.flatnonzero(passed[sel] > len(moves) - 1)
        sel, s, along, step = sel[more], s[more], along[more] + 1.0, step[more]
    return np.concatenate(moves), np.concatenate(to)


class _AxisGraph:
    """One axis over the whole span: per sample its states (at rest on a position, or moving
    since a command: ``chain`` >= 0), each state's position, and the edges into each sample's
    states from the sample before (a rest kept, a move started (one start), a move going on,
    a move stopping on a grid point it passed). States are numbered per sample, rests first;
    a state with no edge into it gets one from a virtual source numbered past the sample's
    states (the programme gives it no finite cost). Edges are in order of their sample, then
    their state; a state's edges: a rest kept, then stops in order of the moving state."""

    def __init__(self, ax: _Axis, ts: np.ndarray, box: tuple[np.ndarray, np.ndarray],
                 starts_deg: np.ndarray, here_deg: float):
        n = len(ts)
        lo = np.maximum(box[0], ax.lo_deg - 1e-9)
        hi = np.minimum(box[1], ax.hi_deg + 1e-9)
        rests = _Rests(ax.grid_deg, lo, hi, starts_deg, here_deg)
        # Moves: from each rest on a cycle instant, either way.
        birth = (rests.samp % 2 == 0) & (rests.samp < n - 1)
        b_samp = np.repeat(rests.samp[birth], 2)
        b_dir = np.tile([1.0, -1.0], int(birth.sum()))
        blocks, n_move = _follow(ax, ts, lo, hi, b_samp, np.repeat(rests.x[birth], 2), b_dir,
                                 rests)
        self.size = size = rests.count + n_move
        self.off = off = np.concatenate(([0], np.cumsum(size)))
        self.b_samp, self.b_dir, self.grid_deg = b_samp, b_dir, ax.grid_deg
        rest_at = np.arange(len(rests.samp)) + (off[:-1] - rests.base)[rests.samp]
        self._states(rests, rest_at, blocks)
        stop_first = self._rest_edges(rests, rest_at, blocks)
        self._move_edges(rests, blocks, birth)
        self._stop_edges(rests, blocks, stop_first)
        self.e_off = self.edge_at[off]
        # A sample with no state in reach: no schedule of the class can pass it.
        self.blocked = bool((size[1:] == 0).any())
        self._trig: tuple[np.ndarray, np.ndarray] | None = None

    def _states(self, rests: _Rests, rest_at: np.ndarray, blocks: list[_Block]) -> None:
        """Each state's position and chain (the rests' overall indices ``rest_at``); each
        moving state's index, overall and in its sample, into its block."""
        self.x = np.empty(self.off[-1])
        self.chain = np.full(self.off[-1], -1)
        self.x[rest_at] = rests.x
        for b in blocks:
            index = np.arange(len(b.s))
            b.at = (self.off[1:] - b.shift)[b.s] + index
            b.local = (self.size - b.shift)[b.s] + index
            self.x[b.at] = b.x
            self.chain[b.at] = b.chain

    def _rest_edges(self, rests: _Rests, rest_at: np.ndarray, blocks: list[_Block]
                    ) -> np.ndarray:
        """Each state's first edge (``edge_at``: a moving state has one, a rest its kept one
        and its stops, or else one from the virtual source), the edges' source and cost
        arrays, and the rests' kept and virtual edges in them. Returns, per rest, where its
        stops begin less the stops into the rests before it (a stop's edge is that plus its
        index among all the stops in order of the rest)."""
        n_rest = len(rests.samp)
        later = np.arange(rests.count[0], n_rest)
        at, found = _lookup(rests.key, rests.key[later] - (1 << 32))  # the sample before
        kept = np.zeros(n_rest, np.int64)
        kept[later[found]] = 1
        stops = np.bincount(np.concatenate([b.stop_to for b in blocks]
                                           + [np.zeros(0, np.int64)]), minlength=n_rest)
        lone = np.zeros(n_rest, bool)
        lone[later] = kept[later] + stops[later] == 0
        self.edge_at = np.ones(int(self.off[-1]) + 1, np.int64)  # a state's edges, summed
        self.edge_at[0] = 0
        self.edge_at[rest_at + 1] = kept + stops + lone
        np.cumsum(self.edge_at, out=self.edge_at)
        n_total = int(self.edge_at[-1])
        self.e_src = np.empty(n_total, np.int64)
        self.e_cost = np.zeros(n_total, np.float32)
        first = self.edge_at[rest_at]
        e = first[later[found]]
        self.e_src[e] = rests.local[at[found]]
        e = first[lone]
        self.e_src[e] = self.size[rests.samp[lone] - 1]
        return first + kept - (np.cumsum(stops) - stops)

    def _move_edges(self, rests: _Rests, blocks: list[_Block], birth: np.ndarray) -> None:
        """The one edge into each moving state: its move started from its rest (one start),
        or it goes on from the step before."""
        # The rest a move starts from, as the first rest of its key; two chains a birth.
        born = rests.local[np.searchsorted(rests.key, rests.key[birth])]
        before: _Block | None = None
        for b in blocks:
            e = self.edge_at[b.at]
            self.e_src[e] = born[b.chain >> 1] if before is None else before.local[b.before]
            if before is None:
                self.e_cost[e] = 1.0
            before = b

    def _stop_edges(self, rests: _Rests, blocks: list[_Block], stop_first: np.ndarray
                    ) -> None:
        """The stops' edges (``stop_first`` of :meth:`_rest_edges`): into a rest after its
        kept one, in order of the moving state."""
        stride = max(int(self.size.max()), 1)  # above any index in a sample
        wide = np.int32 if len(rests.samp) * stride < 2**31 else np.int64  # int32 sorts faster
        key = np.sort(np.concatenate([(b.stop_to * stride + b.local[b.stop_from]).astype(wide)
                                      for b in blocks] + [np.zeros(0, wide)]))
        to, src = np.divmod(key, stride)
        e = stop_first[to] + np.arange(len(key))
        self.e_src[e] = src

    # What only the numpy programme reads (the compiled one reads edge_at itself).

    @cached_property
    def e_dst(self) -> np.ndarray:
        """Each edge's state, as its index in the sample."""
        return np.repeat(np.arange(self.off[-1]) - np.repeat(self.off[:-1], self.size),
                         np.diff(self.edge_at))

    @cached_property
    def e_first(self) -> np.ndarray:
        """Each state's first edge, per sample (states of sample 0 have none)."""
        return self.edge_at[self.off[1]:-1] - np.repeat(self.e_off[1:-1], self.size[1:])

    @cached_property
    def f_off(self) -> np.ndarray:
        return np.concatenate(([0], self.off[1:] - self.off[1]))

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


# Costs of the compiled programme: stored as int16 (half the memory of float32), worked on as
# float32 (numba widens int16 sums to int64, which vectorises poorly), with this for "no
# finite cost" (a start or two added to it still fits, and min() keeps it: no branch in the
# inner loops).
_NONE16 = 16_000


def _programme_compiled(ga: _AxisGraph, ge: _AxisGraph, v0: np.ndarray,
                        stop_bearing_deg: float, target: np.ndarray, min_dot: np.ndarray,
                        checked: np.ndarray) -> _Found | None:
    """:func:`_programme` as compiled loops (:data:`_loops`), with the same result. Sample
    s's costs are stored az-major (``[az][el]``) when s is even, el-major when it is odd
    (:func:`_forward_loop`)."""
    n = len(target)
    v_off = np.concatenate(([0], np.cumsum(ga.size.astype(np.int64) * ge.size)))
    values = np.empty(int(v_off[-1]), np.int16)
    values[:v_off[1]] = np.where(np.isfinite(v0), v0, _NONE16).ravel()
    work = int(max((ga.size[1:] * ge.size[:-1]).max(), (ga.size[:-1] * ge.size[1:]).max(),
                   (ga.size * ge.size).max()))
    sin_b, cos_b = ga.trig(stop_bearing_deg)
    sin_e, cos_e = ge.trig(0.0)
    edges = (ga.off, ga.edge_at, ga.e_src, ga.e_cost, ge.off, ge.edge_at, ge.e_src, ge.e_cost)
    reached = _loops("_forward_loop")(*edges, sin_b, cos_b, sin_e, cos_e, target, min_dot,
                                      checked, v_off, values, np.empty(work, np.float32),
                                      np.empty(work, np.float32))
    if reached < n:
        return None
    last = values[v_off[-2]:]
    last = (last.reshape(ge.size[-1], ga.size[-1]).T if (n - 1) % 2
            else last.reshape(ga.size[-1], ge.size[-1]))
    # The first least-cost pair in az-major order, as _programme takes it.
    a, e = np.unravel_index(int(np.argmin(last)), last.shape)
    if last[a, e] == _NONE16:
        return None
    ka, ke = np.zeros(n, np.int64), np.zeros(n, np.int64)
    ka[-1], ke[-1] = a, e
    _loops("_path_loop")(*edges, v_off, values, ka, ke)
    return ka, ke, int(last[a, e])


def _forward_loop(a_off, a_edge, a_src, a_cost, e_off, e_edge, e_src, e_cost, sin_b, cos_b,
                  sin_e, cos_e, target, min_dot, checked, v_off, values, work, work_t
                  ):  # pragma: no cover - compiled by numba (its twin: _programme)
    """Fills ``values`` from sample 0's; returns the first sample with no finite cost
    (len(target) when there is none). A step's two axes may go in either order (a pair's
    cost is the least over both axes' edges into it, whichever is taken first), so each step
    takes first the axis its sample before is stored major in and stores its sample
    the other way: every relaxation runs along contiguous rows, and a step needs one
    transpose."""
    n = len(target)
    none = np.float32(_NONE16)
    for s in range(1, n):
        pa, pe = a_off[s] - a_off[s - 1], e_off[s] - e_off[s - 1]
        na, ne = a_off[s + 1] - a_off[s], e_off[s + 1] - e_off[s]
        before = values[v_off[s - 1]:v_off[s]]
        if s % 2:  # [az][el] before: az first, stored [el][az]
            _relax(work, na, pe, before, pa, a_edge, a_src, a_cost, a_off[s])
            _transpose(work, na, pe, work_t)
            _relax(work, ne, na, work_t, pe, e_edge, e_src, e_cost, e_off[s])
        else:
            _relax(work, ne, pa, before, pe, e_edge, e_src, e_cost, e_off[s])
            _transpose(work, ne, pa, work_t)
            _relax(work, na, ne, work_t, pa, a_edge, a_src, a_cost, a_off[s])
        if checked[s]:
            _band(work, s % 2 == 1, na, ne, sin_b[a_off[s]:], cos_b[a_off[s]:],
                  sin_e[e_off[s]:], cos_e[e_off[s]:], target[s], min_dot[s])
        finite = 0
        out = values[v_off[s]:v_off[s + 1]]
        for k in range(na * ne):
            out[k] = np.int16(work[k])
            finite += work[k] < none
        if finite == 0:
            return s
    return n


def _relax(out, n_rows, width, src, n_src, edge_at, e_src, e_cost, first
           ):  # pragma: no cover - compiled by numba (in _forward_loop)
    """Row r of ``out`` (rows ``width`` long): the least over the edges into state r (of the
    axis's states from ``first``) of its source's row of ``src`` plus the edge's starts (a
    source at or past ``n_src``, the virtual one, has none). Offsets are unsigned: with a
    signed one numba checks for a negative index in the loop, which then is not
    vectorised."""
    none = np.float32(_NONE16)
    w = np.uint64(width)
    for r in range(n_rows):
        row = np.uint64(r) * w
        for j in range(np.uint64(0), w):
            out[row + j] = none
        for k in range(edge_at[first + r], edge_at[first + r + 1]):
            if e_src[k] < n_src:
                at, cost = np.uint64(e_src[k]) * w, np.float32(e_cost[k])
                for j in range(np.uint64(0), w):
                    x = np.float32(src[at + j]) + cost
                    out[row + j] = x if x < out[row + j] else out[row + j]


def _transpose(src, rows, cols, out
               ):  # pragma: no cover - compiled by numba (in _forward_loop)
    n_rows, n_cols = np.uint64(rows), np.uint64(cols)  # unsigned: as in _relax
    for i in range(np.uint64(0), n_rows):
        for j in range(np.uint64(0), n_cols):
            out[j * n_rows + i] = src[i * n_cols + j]


def _band(work, el_major, na, ne, sin_b, cos_b, sin_e, cos_e, target, min_dot
          ):  # pragma: no cover - compiled by numba (in _forward_loop)
    """No finite cost where a pair's boresight is out of the band (as :func:`_feasible`),
    along ``work``'s rows."""
    none = np.float32(_NONE16)
    if el_major:
        for j in range(ne):
            lim, c = min_dot - sin_e[j] * target[2], cos_e[j]
            row = work[j * na:(j + 1) * na]
            for i in range(na):
                row[i] = row[i] if (sin_b[i] * target[0] + cos_b[i] * target[1]) * c >= lim \
                    else none
    else:
        for i in range(na):
            along = sin_b[i] * target[0] + cos_b[i] * target[1]
            row = work[i * ne:(i + 1) * ne]
            for j in range(ne):
                row[j] = row[j] if along * cos_e[j] >= min_dot - sin_e[j] * target[2] \
                    else none


def _path_loop(a_off, a_edge, a_src, a_cost, e_off, e_edge, e_src, e_cost, v_off, values, ka,
               ke):  # pragma: no cover - compiled by numba (its twin: _programme's last loop)
    """Back from the pair in ``ka[-1], ke[-1]``: the first least-cost predecessor pair of each
    sample's, in edge order, into ``ka``, ``ke`` (the samples stored as
    :func:`_forward_loop` stores them)."""
    for s in range(len(ka) - 1, 0, -1):
        a, e = ka[s], ke[s]
        pa, pe = a_off[s] - a_off[s - 1], e_off[s] - e_off[s - 1]
        na, ne = a_off[s + 1] - a_off[s], e_off[s + 1] - e_off[s]
        want = values[v_off[s] + (e * na + a if s % 2 else a * ne + e)]
        for k1 in range(a_edge[a_off[s] + a], a_edge[a_off[s] + a + 1]):
            if a_src[k1] >= pa:
                continue
            for k2 in range(e_edge[e_off[s] + e], e_edge[e_off[s] + e + 1]):
                if e_src[k2] >= pe:
                    continue
                p = a_src[k1] * pe + e_src[k2] if s % 2 else e_src[k2] * pa + a_src[k1]
                x = values[v_off[s - 1] + p]
                if x < _NONE16 and x + a_cost[k1] + e_cost[k2] == want:
                    ka[s - 1], ke[s - 1] = a_src[k1], e_src[k2]
                    break
            else:
                continue
            break


_loops = compiled.Loops(globals(), helpers=("_relax", "_transpose", "_band"))


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
