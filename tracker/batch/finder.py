"""Catalogue-scale pass finder on sgp4's SatrecArray + numpy.

How one job runs (every step is numpy over all satellites of a chunk at once):

1. **Screen** on a coarse grid (up to ``ARC_LIMIT_RAD`` of orbit, <= 2 h): SGP4 at each coarse
   time for the whole chunk (one ``SatrecArray`` call). Between two coarse samples the
   satellite stays (within perturbations) in the orbit plane given by the orbit normal r x v,
   sweeping the arc between them. A satellite can only rise above ``min_el`` within the
   interval if the arc comes within the *horizon cone* (geocentric angle for that elevation
   at the orbit's apogee) of the station, widened by the station's own motion and a margin
   for perturbations. Inside a candidate interval the same test runs per fine step, with the
   sub-arc bounded by the slowest/fastest angular rate (no SGP4). Steps that fail are skipped.
2. **Sample** the candidate fine steps at both ends (``step_s`` for low orbits, longer in
   proportion for slower ones), sharing the TEME -> ITRS rotation of each grid time across
   every satellite and station; elevation *and* its rate come from the SGP4 position and
   velocity, so maxima are found by the rate's sign change.
3. **Bracket** AOS/LOS (sign changes of elevation - horizon), maxima (rate + -> -), and
   near-miss maxima: a maximum whose bound from the two ends is close below the threshold is
   refined too, so short grazing passes inside one fine step are not lost.
4. **Refine** all brackets at once on the cubic Hermite interpolant of the TEME position
   (from the samples' positions and velocities; no SGP4), working on sin(elevation) and its
   analytic time derivatives (no arcsin/arctan2 in the iterations without a horizon mask),
   then finish each root with one SGP4 evaluation and a Newton step on its local Taylor
   series (a second SGP4 call only for the rare root that moved by more than a second):
   about one SGP4 call per event, to ``tol_s``.

The fused per-element loops of steps 1-4 (fine screen, look angles, flags and brackets of
the samples, first guesses, the cubics, the solves on them and the correction from SGP4's
state), and of the assembly (Sun flags, the result's order) live in
:mod:`tracker.batch.kernels`, in numpy and as compiled loops when numba is installed.

Steps 3 and 4 run for all stations of a chunk at once (a station index per sample and
bracket), in groups of stations sized by the memory budget; a pass does not depend on the
other stations (bit for bit). What is station-independent is computed once for all of them:
the coarse SGP4 screen, the fine samples' SGP4 states, and the sub-arcs of each coarse
interval that the fine screen tests against each station's cone. The refinement's SGP4
evaluation is per event: a satellite's events at different stations fall at different
times, and interpolating shared states instead is not accurate enough for grazing passes
(SGP4's velocity differs from the derivative of its position by about 1 cm/s, up to
0.5 m/s, so a Hermite interpolant through its states is off by metres over minutes).

SGP4 errors (decayed elements) are collected per satellite and reported, never raised.
Memory is bounded by chunking over satellites (sized from ``memory_mb``) and over time (blocks
of at most ``block_days``; passes cut at a block edge are joined again). The result itself is
held whole by :func:`find_passes_batch`; :func:`iter_passes_batch` gives it in parts and keeps
rows beyond the budget in temporary files meanwhile (:class:`tracker.spill.RowSpill`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from functools import cached_property

import numpy as np
from sgp4.api import SGP4_ERRORS, SatrecArray, jday

from tracker.batch import geometry as geo
from tracker.batch import kernels
from tracker.errors import ConfigError
from tracker.spill import RowSpill
from tracker.station import Station

PASS_DTYPE = np.dtype([
    ("sat", np.int32), ("station", np.int32),
    ("aos_s", np.float64), ("tca_s", np.float64), ("los_s", np.float64),
    ("max_el_deg", np.float64), ("aos_az_deg", np.float64), ("tca_az_deg", np.float64),
    ("los_az_deg", np.float64), ("aos_clipped", np.bool_), ("los_clipped", np.bool_),
    ("sunlit", np.bool_), ("visible", np.bool_),
])

# A coarse arc may sweep up to ~290 deg: its plane comes from the orbit normal (r x v), not
# from its two ends, so arcs beyond 180 deg are unambiguous.
ARC_LIMIT_RAD = 5.0
PERTURBATION_MARGIN_RAD = math.radians(0.5)
ELLIPSOID_MARGIN_DEG = 0.5  # geodetic vs geocentric vertical (< 0.2 deg) plus slack
TWILIGHT_DEG = -6.0
MAX_COARSE_S = 7200.0
MAX_FINE_S = 3600.0
CORRECT_ROUNDS = 3
CORRECT_SPAN_S = 1.0
SOLVE_TOL_S = 10.0
LEO_RATE_RAD_S = 1.1e-3  # a ~95-minute orbit: step_s is the fine step at this rate


@dataclass(frozen=True)
class SatError:
    """SGP4 could not propagate satellite ``sat`` from ``first_s`` (POSIX UTC) on."""

    sat: int
    name: str
    code: int
    message: str
    first_s: float


@dataclass
class PassTable:
    """The finder's result: one row per (satellite, station) pass, sorted by AOS.

    Times are POSIX UTC seconds; ``aos_clipped``/``los_clipped`` mark passes already in
    progress at the window start / still in progress at its end (or cut by decay).
    """

    passes: np.ndarray
    names: list[str]
    stations: list[Station]
    start: datetime
    end: datetime
    errors: list[SatError] = field(default_factory=list)
    stats: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.passes)

    def select(self, mask) -> PassTable:
        return PassTable(self.passes[mask], self.names, self.stations, self.start, self.end,
                         self.errors, self.stats)

    @classmethod
    def concat(cls, parts: list[PassTable]) -> PassTable:
        """Consecutive parts of one table (as :func:`iter_passes_batch` gives them) as one
        (a single part is returned as it is)."""
        first = parts[0]
        if len(parts) == 1:
            return first
        passes = np.concatenate([p.passes for p in parts])
        return cls(passes, first.names, first.stations, first.start, first.end, first.errors,
                   first.stats)


@dataclass
class _Job:
    satrecs: list
    frames: geo.StationFrames
    stations: list[Station]
    jd0: float
    fr0: float
    window_s: float
    dut1_s: float
    step_s: float
    tol_s: float
    stats: dict
    errors: dict  # sat -> (tau_s, code)
    memory_mb: float = 256.0
    _theta0: float | None = None
    _theta_rate: float = 0.0

    def theta(self, tau):
        # GMST 1982 is linear in time to 1e-12 rad over weeks (its T^2 term is 0.09 s per
        # century squared), so one evaluation at the block start serves every time.
        if self._theta0 is None:
            from skyfield.sgp4lib import theta_GMST1982

            theta0, rate = theta_GMST1982(self.jd0, self.fr0 + self.dut1_s / geo.DAY_S)
            self._theta0, self._theta_rate = float(theta0), float(rate) / geo.DAY_S
        return self._theta0 + self._theta_rate * np.asarray(tau, dtype=float)

    def fr(self, tau):
        return self.fr0 + np.asarray(tau, dtype=float) / geo.DAY_S

    def note_errors(self, sat, tau, code) -> None:
        bad = np.flatnonzero(code != 0)
        for i in bad[np.argsort(tau[bad], kind="stable")].tolist():
            s = int(sat[i])
            if s not in self.errors or tau[i] < self.errors[s][0]:
                self.errors[s] = (float(tau[i]), int(code[i]))

    def threshold(self, st, az_deg):
        """The horizon (deg) at azimuths for stations ``st``: min elevation, raised by masks."""
        if np.ndim(st) == 0:
            mask = self.stations[st].mask
            base = float(self.frames.min_el_deg[st])
            return base if mask is None else np.maximum(base, mask.min_el_at(az_deg))
        thr = self.frames.min_el_deg[st]
        for k in self.masked:
            m = st == k
            if m.any():
                thr[m] = np.maximum(thr[m], self.stations[k].mask.min_el_at(az_deg[m]))
        return thr

    @cached_property
    def masked(self) -> list[int]:
        """The stations with a horizon mask."""
        return [k for k, s in enumerate(self.stations) if s.mask is not None]

    @cached_property
    def deep_space(self) -> np.ndarray:
        """Per satellite: propagated by SDP4 (period of 225 minutes or more)."""
        return np.array([sr.method == "d" for sr in self.satrecs], dtype=bool)

    @cached_property
    def sky(self) -> kernels.Sky:
        """What the kernels need to turn TEME states into sin(elevation) at the stations."""
        self.theta(0.0)
        f = self.frames
        return kernels.Sky(float(self._theta0), self._theta_rate, f.ecef_km, f.up, f.east,
                           f.north, self.sin_min_el)

    @cached_property
    def sin_min_el(self) -> np.ndarray:
        """sin(min elevation) per station (the AOS/LOS target without a mask)."""
        return np.array([math.sin(math.radians(x)) for x in self.frames.min_el_deg.tolist()])


def _sgp4_pairs(job: _Job, sat: np.ndarray, tau: np.ndarray, kind: str = "sgp4_refine"):
    """SGP4 for (satellite, time) pairs: one ``sgp4_array`` call per distinct satellite."""
    m = len(sat)
    if m == 0:
        return np.zeros(0, np.int32), np.empty((0, 3)), np.empty((0, 3))
    step = sat[1:] - sat[:-1]
    presorted = bool(np.all((step > 0) | ((step == 0) & (tau[1:] >= tau[:-1]))))
    order = np.arange(m) if presorted else _satellite_order(job, sat, tau)
    s_sorted = sat if presorted else sat[order]
    jd = np.full(m, job.jd0)
    fr = job.fr(tau if presorted else tau[order])
    cuts = np.flatnonzero(np.diff(s_sorted)) + 1
    starts = np.concatenate([[0], cuts]).astype(np.int64)
    ends = np.concatenate([cuts, [m]]).tolist()
    e_s = np.empty(m, np.uint8)
    r_s = np.empty((m, 3))
    v_s = np.empty((m, 3))
    satrecs = job.satrecs
    for i, a, b in zip(s_sorted[starts].tolist(), starts.tolist(), ends, strict=True):
        # Satrec.sgp4_array without its per-call allocations: SGP4 writes into the slices.
        satrecs[i]._sgp4(jd[a:b], fr[a:b], e_s[a:b], r_s[a:b], v_s[a:b])
    if presorted:
        err, r, v = e_s.astype(np.int32), r_s, v_s
    else:  # back to the given order: gathers by the inverse permutation (faster than scatters)
        inv = np.empty(m, np.int64)
        inv[order] = np.arange(m)
        err, r, v = e_s.take(inv).astype(np.int32), r_s.take(inv, 0), v_s.take(inv, 0)
    job.stats[kind] = job.stats.get(kind, 0) + m
    job.note_errors(sat, tau, err)
    return err, r, v


def _satellite_order(job: _Job, sat: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Indices grouping (satellite, time) pairs by satellite, for one SGP4 call each.

    A deep-space (SDP4) satellite's times go in increasing order: its resonance integrator
    restarts from the epoch whenever time goes backwards (30 % slower shuffled). SGP4 keeps
    no state between times, so near-Earth satellites keep the given order: an integer sort
    costs a tenth of sorting every pair by time too, and SGP4 gives the same values in any
    order."""
    # A stable sort of 16-bit keys is a radix sort: 8 times faster than of int64 ones.
    order = np.argsort(sat.astype(np.uint16) if len(job.satrecs) <= 2**16 else sat,
                       kind="stable")
    deep = np.flatnonzero(job.deep_space[sat[order]])
    if deep.size:
        sub = order[deep]
        order[deep] = sub[np.lexsort((tau[sub], sat[sub]))]
    return order


def _finite(x):
    """Rows of (..., 3) vectors with all components finite (NaN and inf propagate)."""
    return np.isfinite(x[..., 0] + x[..., 1] + x[..., 2])


def _gravity(r):
    """Two-body acceleration (km/s^2) at TEME positions (n, 3)."""
    n2 = np.einsum("ij,ij->i", r, r)
    return r * (-geo.MU_KM3_S2 / (n2 * np.sqrt(n2)))[:, None]


def _newton_step(job: _Job, st, t: kernels.Topo, tca: bool):
    """(g, Newton step to g's root) at points ``t`` (of stations ``st``), where g is
    d sin(el)/dt for a culmination and, for AOS/LOS, sin(el) - sin(horizon) (second-order
    step: sin(el) is curved on the scale of a grazing pass) or, with a horizon mask,
    el - mask(az) in deg."""
    g, step = kernels.newton_sin_el(t.s, t.s1, t.s2, job.sin_min_el[st], tca)
    masked = job.masked
    if masked and not tca:
        with np.errstate(divide="ignore", invalid="ignore"):
            i = np.flatnonzero(np.isin(st, masked))
            tm, sm = t.take(i), st[i]
            el = tm.el_deg()
            rate = np.degrees(tm.s1 / np.sqrt(np.maximum(1.0 - tm.s * tm.s, 1e-12)))
            g[i] = el - job.threshold(sm, tm.az_deg(job.sky, sm))
            step[i] = g[i] / rate
    return g, step


def _refine(job: _Job, st, sat, lo, hi, lo_neg, guess, cubic, tca: bool):
    """AOS/LOS (``tca`` False) or culminations in brackets [lo, hi] of satellites ``sat``
    seen from stations ``st``: (tau, el, az, r_teme).

    1. Newton steps on the cubic interpolant ``cubic`` (no SGP4; second order for AOS/LOS)
       until one is below ``SOLVE_TOL_S``; the point after it is then usually within a
       fraction of a second of the cubic's root (one or two evaluations per event).
    2. SGP4 there, usually the only evaluation: within ``CORRECT_SPAN_S`` SGP4's state is
       its Taylor series with two-body acceleration (millimetres), so the Newton step from
       SGP4's exact values lands on SGP4's own root, and the Taylor state gives the look
       angles there and the residual (further steps while it exceeds ``tol_s``).
    3. A root that moved by more than ``CORRECT_SPAN_S`` (grazing passes, whose flat
       elevation magnifies the cubic's error) is solved again on the cubic corrected by
       SGP4's state error at that point and gets another SGP4 evaluation there.
    """
    n = len(lo)
    if n == 0:
        z = np.zeros(0)
        return z, z, z, np.zeros((0, 3))
    key = "brackets_tca" if tca else "brackets_cross"
    job.stats[key] = job.stats.get(key, 0) + n

    def model(k, tau):
        r, v, a = cubic.corrected(k, tau)
        return kernels.topo(job.sky, st[k], tau, r, v, a), r

    # Brackets of stations with a horizon mask are solved with the numpy kernels and
    # _newton_step, the others with the kernels' own arithmetic: a station's passes do not
    # depend on which stations share its group (the two agree to rounding only).
    masked = np.isin(st, job.masked) if job.masked else np.zeros(n, bool)

    def on_cubic(k, tau, tol_s):
        """Roots on the (corrected) cubic of brackets ``k`` from ``tau``."""
        m = masked[k]
        out = np.empty(len(k))
        k0, k1 = k[~m], k[m]
        out[~m] = kernels.solve_cubic(job.sky, cubic, k0, st[k0], lo[k0], hi[k0], lo_neg[k0],
                                      tau[~m], tol_s, tca)
        if k1.size:
            out[m] = kernels.solve(
                lambda j, t: _newton_step(job, st[k1[j]], model(k1[j], t)[0], tca),
                lo[k1], hi[k1], lo_neg[k1], tau[m], tol_s)
        return out

    x = on_cubic(np.arange(n), guess, SOLVE_TOL_S)
    lo, hi = lo.copy(), hi.copy()
    tau = x.copy()
    el, az, r_out = np.zeros(n), np.zeros(n), np.zeros((n, 3))
    active = np.arange(n)
    for _ in range(CORRECT_ROUNDS):
        if active.size == 0:
            break
        xa = x[active]
        err, r_s, v_s = _sgp4_pairs(job, sat[active], xa)
        ok = (err == 0) & _finite(r_s) & _finite(v_s)
        if not ok.all():  # decayed: keep the cubic's state
            k = np.flatnonzero(~ok)
            r_s[k], v_s[k], _ = cubic(active[k], xa[k])
        # Within CORRECT_SPAN_S of xa, SGP4's state is its Taylor series with two-body
        # acceleration (J2 and lunisolar terms change it by < 1e-3: millimetres).
        x1, far = _correct(job, masked[active], active, xa, r_s, v_s, st, lo, hi, lo_neg,
                           tca, (tau, el, az, r_out))
        far = np.flatnonzero(far & ok)
        if far.size:
            # Far off (grazing passes): solve again on the cubic corrected by SGP4's state
            # error at xa (to first order; then good to metres over the step), like step 1.
            k = active[far]
            r_c, v_c, _ = cubic(k, xa[far])
            cubic.x_ref[k], cubic.dr[k], cubic.dv[k] = xa[far], r_s[far] - r_c, v_s[far] - v_c
            x1[far] = on_cubic(k, x1[far], 0.1)
        x[active] = x1
        active = active[far]
    if active.size:  # still moving after CORRECT_ROUNDS: take the last corrected point
        t1, r1 = model(active, x[active])
        tau[active], r_out[active] = x[active], r1
        el[active], az[active] = t1.el_deg(), t1.az_deg(job.sky, st[active])
    return tau, el, az, r_out


def _correct(job: _Job, masked, active, xa, r_s, v_s, st, lo, hi, lo_neg, tca: bool, out):
    """:func:`kernels.correct` of brackets ``active`` from SGP4's states at ``xa``: with
    :func:`_newton_step` where the station has a horizon mask (``masked``), with the
    kernels' own arithmetic elsewhere."""
    a_s = _gravity(r_s)
    if not masked.any():
        return kernels.correct(job.sky, active, xa, r_s, v_s, a_s, st, lo, hi, lo_neg,
                               job.tol_s, CORRECT_SPAN_S, tca, out)
    x1, far = np.empty(len(active)), np.empty(len(active), bool)
    for part, newton in ((~masked, None),
                         (masked, lambda st_k, t: _newton_step(job, st_k, t, tca))):
        x1[part], far[part] = kernels.correct(
            job.sky, active[part], xa[part], r_s[part], v_s[part], a_s[part], st, lo, hi,
            lo_neg, job.tol_s, CORRECT_SPAN_S, tca, out, newton)
    return x1, far


def _arc_geometry(r, v, valid):
    """The orbit arcs between consecutive coarse samples: start direction A, in-plane normal
    q, pole h (unit vectors, (S, K, 3)), the swept angle phi in [0, 2 pi) (S, K) and the
    cosine and sine of phi / 2.

    The plane's pole is the mean of the two ends' orbit normals (r x v), so the plane is
    well defined for any arc length and follows the slow nodal drift to first order.
    """
    def unit(x):
        n = np.sqrt(_dot3(x, x))[..., None]
        return x / np.where(n > 0, n, 1.0)

    w = unit(_cross3(r, v))
    h_hat = unit(w[:, :-1] + w[:, 1:])
    r_hat = unit(r)
    a_hat, b_hat = r_hat[:, :-1], r_hat[:, 1:]
    # A and B projected into the plane (they lie within perturbations of it).
    A = unit(a_hat - _dot3(a_hat, h_hat)[..., None] * h_hat)
    q = _cross3(h_hat, A)
    phi = np.mod(np.arctan2(_dot3(b_hat, q), _dot3(b_hat, A)), 2 * math.pi)
    return dict(A=A, B=b_hat, q=q, h=h_hat, phi=phi, cos_half=np.cos(0.5 * phi),
                sin_half=np.sin(0.5 * phi), ok=valid[:, :-1] & valid[:, 1:])


def _dot3(a, b):
    """Dot products of (..., 3) vectors (no einsum parsing on the hot path)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _cross3(a, b):
    """Cross products of (..., 3) vectors, component by component (np.cross moves axes)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


def _station_teme(job: _Job, st: int, tau) -> np.ndarray:
    """Station ``st``'s geocentric unit vector in TEME at times ``tau`` (..., 3)."""
    theta = job.theta(tau)
    c, s = np.cos(theta), np.sin(theta)
    u = job.frames.unit[st]
    return np.stack([c * u[0] - s * u[1], s * u[0] + c * u[1], np.full_like(c, u[2])], -1)


def _cone_limits(job: _Job, st: int, r_apo, dt_s: float):
    """cos/sin of the screening cone half-angle (per satellite): the horizon cone at apogee,
    widened by the station's motion in ``dt_s / 2`` and the perturbation margin."""
    frames = job.frames
    lim = (geo.horizon_angle_rad(r_apo, frames.radius_km[st],
                                 frames.min_el_deg[st] - ELLIPSOID_MARGIN_DEG)
           + geo.EARTH_ROTATION_RAD_S * dt_s / 2.0 * frames.cos_lat[st]
           + PERTURBATION_MARGIN_RAD)
    return np.cos(np.minimum(lim, math.pi)), np.sin(np.minimum(lim, math.pi / 2))


def _coarse_candidates(job: _Job, arc, tau_c, coarse_s, r_apo, screenable):
    """Per station, (S, K) booleans: coarse intervals where a pass is geometrically possible."""
    A, B, q, h_hat = arc["A"], arc["B"], arc["q"], arc["h"]
    out = []
    for k in range(len(job.frames)):
        p = _station_teme(job, k, 0.5 * (tau_c[:-1] + tau_c[1:]))
        cos_lim, sin_lim = (x[:, None] for x in _cone_limits(job, k, r_apo, coarse_s))
        pa = np.einsum("skc,kc->sk", A, p)
        pb = np.einsum("skc,kc->sk", B, p)
        ph = np.einsum("skc,kc->sk", h_hat, p)
        pq = np.einsum("skc,kc->sk", q, p)
        # The station's in-plane direction lies within the arc iff it is within phi / 2 of
        # the arc's middle: its projection there is >= R cos(phi / 2).
        in_arc = (pa * arc["cos_half"] + pq * arc["sin_half"]
                  >= np.sqrt(pa * pa + pq * pq) * arc["cos_half"])
        cand = (pa >= cos_lim) | (pb >= cos_lim) | (in_arc & (np.abs(ph) <= sin_lim))
        cand |= ~screenable[:, None]
        out.append(cand & arc["ok"])
    return out


def _fine_candidates(job: _Job, st: int, cand, arc, n: int, coarse_s, r_apo, ecc,
                     screenable, shared=None):
    """(S, K * n) booleans: fine steps of the candidate coarse intervals where a pass is still
    possible.

    Inside a coarse interval the direction moves monotonically along the arc; its angle from
    A after time t is bracketed by the slowest and fastest angular rate, taken as the arc's
    mean rate times the Kepler perigee/apogee rate ratio for the eccentricity (plus 1 % for
    SGP4's short-period terms and drag). Each fine step then sweeps a sub-arc of known
    bounds, tested against the horizon cone like the coarse interval
    (:func:`kernels.fine_screen`). No SGP4 calls. ``shared``: (:func:`kernels.shared_arcs`
    of the coarse intervals of any station, their rows (S, K)) when many stations share them.
    """
    S, K = cand.shape
    out = np.zeros((S, K * n), bool)
    if n == 1:
        out[:] = cand
        return out
    ss, kk = np.nonzero(cand)
    if ss.size == 0:
        return out
    fine_s = coarse_s / n
    # The station (geocentric unit vector) in TEME at the middle of every fine step of the
    # window: rho (cos psi, sin psi), z with psi = GMST + longitude.
    u = job.frames.unit[st]
    psi = job.theta((np.arange(K * n) + 0.5) * fine_s) + math.atan2(u[1], u[0])
    track = kernels.StationTrack(psi, math.hypot(u[0], u[1]), float(u[2]))
    arcs, rows = (None, None) if shared is None else (shared[0], shared[1][ss, kk])
    cos_lim = _cone_limits(job, st, r_apo, fine_s)[0]
    sub = kernels.fine_screen(arc["A"], arc["q"], arc["phi"], ss, kk, ecc, n, coarse_s, track,
                              cos_lim, screenable, arcs, rows)
    out.reshape(S, K, n)[ss, kk] = sub
    return out


def _fine_mask(sub):
    """Fine samples needed: both ends of every candidate fine step."""
    mask = np.zeros((sub.shape[0], sub.shape[1] + 1), bool)
    mask[:, :-1] |= sub
    mask[:, 1:] |= sub
    return mask


def _run_chunk(job: _Job, sat_ids: np.ndarray, n: int, fine_step_s: float, r_apo, ecc,
               screenable):
    """Screen, sample and bracket one chunk of satellites sharing the coarse factor ``n``."""
    stats = job.stats
    K = max(1, math.ceil(job.window_s / (n * fine_step_s)))
    coarse_s = job.window_s / K
    fine_s = coarse_s / n
    nf = K * n
    tau_c = np.arange(K + 1) * coarse_s
    arr = SatrecArray([job.satrecs[i] for i in sat_ids.tolist()])
    e, r, v = arr.sgp4(np.full(K + 1, job.jd0), job.fr(tau_c))
    stats["sgp4_coarse"] = stats.get("sgp4_coarse", 0) + e.size
    valid = (e == 0) & _finite(r)
    if not valid.all():
        ss, kk = np.nonzero(~valid)
        job.note_errors(sat_ids[ss], tau_c[kk], np.where(e[ss, kk] == 0, 6, e[ss, kk]))
    arc = _arc_geometry(r, v, valid)
    cands = _coarse_candidates(job, arc, tau_c, coarse_s, r_apo, screenable)
    cand_any = np.logical_or.reduce(cands) if len(cands) > 1 else cands[0]
    shared = None
    if len(cands) > 1 and n > 1:  # the sub-arcs of an interval are the same for every station
        ss, kk = np.nonzero(cand_any)
        rows = np.full(cand_any.shape, -1, np.int64)
        rows[ss, kk] = np.arange(len(ss))
        shared = (kernels.shared_arcs(arc["phi"], ss, kk, ecc, n, coarse_s), rows)
    subs = [_fine_candidates(job, st, cand, arc, n, coarse_s, r_apo, ecc, screenable,
                             shared) for st, cand in enumerate(cands)]
    del shared
    sub_any = np.logical_or.reduce(subs) if len(subs) > 1 else subs[0]
    # "intervals": fine steps of the whole window; "candidate_intervals": those the two
    # screening levels kept (the only ones SGP4 samples).
    for key, val in (("coarse_intervals", cand_any.size),
                     ("candidate_coarse_intervals", int(cand_any.sum())),
                     ("intervals", sub_any.size), ("candidate_intervals", int(sub_any.sum()))):
        stats[key] = stats.get(key, 0) + val

    F = _fine_mask(sub_any)
    flat = np.flatnonzero(F)
    s_loc = flat // (nf + 1)
    j = flat % (nf + 1)
    P = np.empty((len(flat), 3))
    V = np.empty((len(flat), 3))
    ok = np.ones(len(flat), bool)
    on_c = j % n == 0
    P[on_c] = r[s_loc[on_c], j[on_c] // n]
    V[on_c] = v[s_loc[on_c], j[on_c] // n]
    ok[on_c] = valid[s_loc[on_c], j[on_c] // n]
    off = ~on_c
    e_f, P[off], V[off] = _sgp4_pairs(job, sat_ids[s_loc[off]], j[off] * fine_s, "sgp4_fine")
    ok[off] = (e_f == 0) & _finite(P[off])
    theta_f = job.theta(np.arange(nf + 1) * fine_s)
    r_ecef, v_ecef = geo.teme_to_ecef(P, V, theta_f[j])

    pos = np.cumsum(F.ravel()) - 1 if len(cands) > 1 else None
    picks = [np.arange(len(flat)) if pos is None else pos[np.flatnonzero(_fine_mask(sub))]
             for sub in subs]
    for group in _station_groups([len(p) for p in picks], job.memory_mb):
        sel = np.concatenate([picks[st] for st in group])
        if sel.size == 0:
            continue
        st = np.repeat(np.asarray(group, np.int64), [len(picks[k]) for k in group])
        yield _station_samples(job, st, sel, s_loc, j, ok, sat_ids, r_apo, fine_s, P, V,
                               r_ecef, v_ecef)


def _station_groups(sizes: list[int], memory_mb: float) -> list[list[int]]:
    """Consecutive stations whose samples together stay within the memory budget (about
    1 kB per sample through bracketing and refinement); at least one station per group."""
    limit = max(1, int(memory_mb * 2**20 / 1024))
    groups: list[list[int]] = []
    total = 0
    for st, n in enumerate(sizes):
        if not groups or (total + n > limit and groups[-1]):
            groups.append([])
            total = 0
        groups[-1].append(st)
        total += n
    return groups


def _station_samples(job: _Job, st, sel, s_loc, j, ok, sat_ids, r_apo, fine_s: float, P, V,
                     r_ecef, v_ecef) -> dict:
    """The brackets of the shared fine samples ``sel`` as seen from stations ``st`` (one per
    sample; each station's samples consecutive, in time order): the samples they need
    (:func:`kernels.station_brackets`) with their look angles, and the AOS, LOS, maximum
    and cut brackets as positions among them."""
    def azimuth(i):
        return geo.look_angles(tuple(c[sel[i]] for c in r_ecef),
                               tuple(c[sel[i]] for c in v_ecef), job.frames, st[i])[1]

    # Azimuths only where used: under a horizon mask and at window-edge cuts.
    masked = np.flatnonzero(np.isin(st, job.masked)) if job.masked else np.zeros(0, np.int64)
    az_masked = azimuth(masked)
    az = np.full(len(sel), np.nan)
    az[masked] = az_masked
    keep, el, rate, f, aos_i, los_i, max_i, cs, ce = kernels.station_brackets(
        job.frames, r_ecef, v_ecef, sel, st, job.threshold(st, az), ok, s_loc, j)
    st, sel = st[keep], sel[keep]
    az = az[keep]
    # Up samples with no contiguous neighbour: the window edge (or decay) cuts the pass.
    cut = np.union1d(cs, ce)
    cut = cut[np.isnan(az[cut])]
    az[cut] = geo.look_angles(tuple(c[sel[cut]] for c in r_ecef),
                              tuple(c[sel[cut]] for c in v_ecef), job.frames, st[cut])[1]
    ss = s_loc[sel]
    return dict(st=st, sat=sat_ids[ss], tau=j[sel] * fine_s, f=f, rate=rate, el=el, az=az,
                aos_i=aos_i, los_i=los_i, max_i=max_i, cut_start=cs, cut_end=ce,
                fine_s=fine_s, r=P.take(sel, 0), v=V.take(sel, 0), r_apo=r_apo[ss])


def _refine_station_chunk(job: _Job, b: dict):
    """Turn stations' samples (:func:`_station_samples`) into pass rows (refined AOS, TCA,
    LOS), all stations' brackets at once."""
    st, sat, tau, f, rate, el, az, r, aos_i, los_i, max_i = (b[k] for k in (
        "st", "sat", "tau", "f", "rate", "el", "az", "r", "aos_i", "los_i", "max_i"))
    h = b["fine_s"]
    # Maxima: refine those that could reach the threshold (near misses inside one step too).
    job.theta(0.0)
    bound = kernels.peak_bound_deg(job._theta0, job._theta_rate, job.frames, max_i, st, tau, r,
                                   b["r_apo"], h, PERTURBATION_MARGIN_RAD)
    max_i = max_i[bound >= job.frames.min_el_deg[st[max_i]] - ELLIPSOID_MARGIN_DEG]
    guess = tau[max_i] + h * kernels.hermite_root(el[max_i], rate[max_i], el[max_i + 1],
                                                  rate[max_i + 1], h, slope=True)
    cubic = kernels.Cubic.between(tau, h, b["r"], b["v"], max_i)
    m_st = st[max_i]
    m_tau, m_el, m_az, m_r = _refine(job, m_st, sat[max_i], tau[max_i], tau[max_i + 1],
                                     np.zeros(len(max_i), bool), guess, cubic, tca=True)
    m_f = m_el - job.threshold(m_st, m_az)
    hidden = (m_f >= 0) & (f[max_i] < 0) & (f[max_i + 1] < 0)

    # Crossing brackets: grid sign changes plus both sides of each hidden pass.
    hi_idx = max_i[hidden]
    zeros = np.zeros(len(hi_idx))
    c_sat = np.concatenate([sat[aos_i], sat[los_i], sat[hi_idx], sat[hi_idx]])
    c_st = np.concatenate([st[aos_i], st[los_i], st[hi_idx], st[hi_idx]])
    c_lo = np.concatenate([tau[aos_i], tau[los_i], tau[hi_idx], m_tau[hidden]])
    c_hi = np.concatenate([tau[aos_i + 1], tau[los_i + 1], m_tau[hidden], tau[hi_idx + 1]])
    c_glo = np.concatenate([f[aos_i], f[los_i], f[hi_idx], m_f[hidden]])
    c_ghi = np.concatenate([f[aos_i + 1], f[los_i + 1], m_f[hidden], f[hi_idx + 1]])
    c_kind = np.concatenate([np.zeros(len(aos_i), int), np.ones(len(los_i), int),
                             np.zeros(len(hi_idx), int), np.ones(len(hi_idx), int)])
    d_lo = np.concatenate([rate[aos_i], rate[los_i], rate[hi_idx], zeros])
    d_hi = np.concatenate([rate[aos_i + 1], rate[los_i + 1], zeros, rate[hi_idx + 1]])
    width = c_hi - c_lo
    guess = c_lo + width * kernels.hermite_root(c_glo, d_lo, c_ghi, d_hi, width)
    c_iv = np.concatenate([aos_i, los_i, hi_idx, hi_idx])
    cubic = kernels.Cubic.between(tau, h, b["r"], b["v"], c_iv)
    c_tau, c_el, c_az, c_r = _refine(job, c_st, c_sat, c_lo, c_hi, c_glo < 0, guess, cubic,
                                     tca=False)

    # Window-edge (or decay) cuts become clipped AOS/LOS at the sample itself.
    cs, ce = b["cut_start"], b["cut_end"]
    ev = dict(
        sat=np.concatenate([c_sat, sat[cs], sat[ce]]),
        st=np.concatenate([c_st, st[cs], st[ce]]),
        tau=np.concatenate([c_tau, tau[cs], tau[ce]]),
        kind=np.concatenate([c_kind, np.zeros(len(cs), int), np.ones(len(ce), int)]),
        az=np.concatenate([c_az, az[cs], az[ce]]),
        el=np.concatenate([c_el, el[cs], el[ce]]),
        r=np.concatenate([c_r, r.take(cs, 0), r.take(ce, 0)]),
        clip=np.concatenate([np.zeros(len(c_sat), bool), np.ones(len(cs) + len(ce), bool)]))
    mx = dict(sat=sat[max_i], st=m_st, tau=m_tau, el=m_el, az=m_az, r=m_r)
    return _assemble(job, ev, mx)


def _pair_keys(job: _Job, ev: dict, mx: dict):
    """Integer keys (satellite and station pair, microsecond) of the events and maxima: the
    pairing is then independent of how satellites are numbered in this chunk, so every
    chunking gives the same passes. Pairs are ranked densely when needed for the keys to fit
    in int64 (2 * 10**6 pairs fit as they are, with room to append a bit)."""
    pair = [x["st"].astype(np.int64) * len(job.satrecs) + x["sat"] for x in (ev, mx)]
    us = [np.round(x["tau"] * 1e6).astype(np.int64) for x in (ev, mx)]
    if len(job.satrecs) * len(job.stations) > PAIRS_AS_THEY_ARE:
        rank = np.unique(np.concatenate(pair), return_inverse=True)[1].reshape(-1)
        pair = [rank[:len(pair[0])], rank[len(pair[0]):]]
    return pair[0] * 10**12 + us[0], pair[1] * 10**12 + us[1], pair[0], pair[1]


# Satellite-station pairs numbered as they are in _pair_keys' keys: pair * 10**12 + time
# (microseconds, < 10**12 for blocks of at most 10 days), times two, stays within int64.
PAIRS_AS_THEY_ARE = 2 * 10**6


def _assemble(job: _Job, ev: dict, mx: dict) -> np.ndarray:
    """Pair AOS with the next LOS per satellite and station, attach the highest maximum, set
    Sun flags."""
    comb, m_comb, pair, m_pair = _pair_keys(job, ev, mx)
    if len(job.satrecs) * len(job.stations) <= PAIRS_AS_THEY_ARE:  # one key, as lexsort
        order = np.argsort(comb * 2 + ev["kind"], kind="stable")
    else:
        order = np.lexsort((ev["kind"], comb))
    kind, pair_o = ev["kind"][order], pair[order]
    is_pass = (kind[:-1] == 0) & (kind[1:] == 1) & (pair_o[:-1] == pair_o[1:])
    a_idx, l_idx = order[:-1][is_pass], order[1:][is_pass]
    n = len(a_idx)
    rows = np.zeros(n, PASS_DTYPE)
    rows["sat"] = ev["sat"][a_idx]
    rows["station"] = ev["st"][a_idx]
    rows["aos_s"], rows["los_s"] = ev["tau"][a_idx], ev["tau"][l_idx]
    rows["aos_az_deg"], rows["los_az_deg"] = ev["az"][a_idx], ev["az"][l_idx]
    rows["aos_clipped"], rows["los_clipped"] = ev["clip"][a_idx], ev["clip"][l_idx]
    # Default TCA: the higher end (kept only when no interior maximum was refined).
    hi_end = ev["el"][l_idx] > ev["el"][a_idx]
    t_idx = np.where(hi_end, l_idx, a_idx)
    rows["tca_s"], rows["max_el_deg"] = ev["tau"][t_idx], ev["el"][t_idx]
    rows["tca_az_deg"] = ev["az"][t_idx]
    tca_r = ev["r"].take(t_idx, 0)
    if n and len(mx["sat"]):
        pa = comb[a_idx]
        order = np.argsort(pa, kind="stable")
        pi = np.searchsorted(pa[order], m_comb, "right") - 1
        inside = pi >= 0
        pi = order[np.maximum(pi, 0)]
        inside &= (m_comb <= comb[l_idx][pi]) & (m_pair == pair[a_idx][pi])
        inside &= mx["el"] > rows["max_el_deg"][pi]
        sel = np.flatnonzero(inside)
        # The highest maximum of each pass (the last of equal ones); most passes have one.
        many = np.bincount(pi[sel], minlength=n)[pi[sel]] > 1
        if many.any():
            multi = sel[many]
            multi = multi[np.lexsort((mx["el"][multi], pi[multi]))]
            last = np.ones(len(multi), bool)
            last[:-1] = pi[multi][1:] != pi[multi][:-1]
            sel = np.concatenate([sel[~many], multi[last]])
        rows["tca_s"][pi[sel]] = mx["tau"][sel]
        rows["max_el_deg"][pi[sel]] = mx["el"][sel]
        rows["tca_az_deg"][pi[sel]] = mx["az"][sel]
        tca_r[pi[sel]] = mx["r"][sel]
    # Sunlit: the satellite sees the Sun at AOS, TCA or LOS; visible: at one of those
    # instants the station is also in nautical twilight or darker. One call for all three.
    tau = np.concatenate([rows["aos_s"], rows["tca_s"], rows["los_s"]])
    r_ev = ev["r"]
    lit, sun_el_sin = kernels.sun_flags(np.concatenate([r_ev.take(a_idx, 0), tca_r,
                                                        r_ev.take(l_idx, 0)]),
                                        tau, job.jd0, job.fr0, job.theta(tau), job.frames,
                                        np.tile(rows["station"], 3))
    vis = lit & (sun_el_sin < math.sin(math.radians(TWILIGHT_DEG)))
    rows["sunlit"] = lit.reshape(3, n).any(0)
    rows["visible"] = vis.reshape(3, n).any(0)
    return rows


def _chunk_size(n_coarse: int, n_fine: int, n_stations: int, memory_mb: float) -> int:
    fine_share = min(1.0, 0.25 * n_stations)
    per_sat = n_coarse * 500 + n_fine * (24 + 260 * fine_share) + n_fine * 12 * min(
        n_stations, 8)
    return int(min(4096, max(32, memory_mb * 2**20 / per_sat)))


def _to_utc(t: datetime) -> datetime:
    if t.tzinfo is None:
        raise ConfigError(f"time {t!r} has no timezone; give UTC times (e.g. ...+00:00)")
    return t.astimezone(timezone.utc)


@dataclass(frozen=True)
class _GridClasses:
    """Per satellite: the fine step, the coarse factor (fine steps per coarse interval) and the
    screening bounds. Satellites with the same (fine step, coarse factor) share one time grid
    and are screened together."""

    fine_s: np.ndarray
    n_fact: np.ndarray
    r_apo: np.ndarray  # apogee radius (km) with a margin for SGP4's short-period terms
    ecc: np.ndarray
    screenable: np.ndarray

    @classmethod
    def of(cls, satrecs, step_s: float) -> _GridClasses:
        r_apo, rate = geo.orbit_bounds(satrecs)
        ecc = np.clip(np.array([sr.ecco for sr in satrecs], dtype=float), 0.0, 0.999)
        r_apo += 100.0  # SGP4 vs Kepler radius, drag and J2 short-period terms
        # Fine step: step_s for low orbits, an integer multiple of it for slower ones (so
        # satellites group into few chunks), in proportion to the period and at most
        # MAX_FINE_S: what matters for the interpolation between samples is the arc swept per
        # step (GEO: two hours, a 30 degree arc, like a low orbit in 480 s).
        slow = np.floor(np.maximum(LEO_RATE_RAD_S / rate, 1.0))
        fine_s = np.minimum(step_s * slow, max(step_s, step_s * (MAX_FINE_S // step_s)))
        # Coarse factor: as many fine steps per coarse interval as keep the arc within
        # ARC_LIMIT_RAD, at most MAX_COARSE_S.
        n_fact = np.clip(np.floor(np.minimum(ARC_LIMIT_RAD / rate, MAX_COARSE_S) / fine_s), 1,
                         None).astype(int)
        screenable = rate * fine_s * n_fact <= ARC_LIMIT_RAD
        return cls(fine_s, n_fact, r_apo, ecc, screenable)

    def groups(self) -> list[np.ndarray]:
        """Satellite indices per (fine step, coarse factor), in a fixed order."""
        keys = sorted(set(zip(self.fine_s.tolist(), self.n_fact.tolist(), strict=True)))
        return [np.flatnonzero((self.fine_s == f_s) & (self.n_fact == n)) for f_s, n in keys]


def find_passes_block(satrecs, names, stations, start, end, min_el_deg=None, *,
                      step_s: float = 480.0, tol_s: float = 0.02, memory_mb: float = 256.0,
                      ) -> PassTable:
    """One time block of :func:`find_passes_batch` (no joining across blocks)."""
    start, end = _to_utc(start), _to_utc(end)
    job = _block_job(satrecs, stations, start, end, min_el_deg, step_s, tol_s, memory_mb)
    rows = list(_block_rows(job, start))
    passes = np.concatenate(rows) if rows else np.zeros(0, PASS_DTYPE)
    passes = passes[table_order(passes)]
    return PassTable(passes, list(names), list(stations), start, end,
                     _block_errors(job, names, start), job.stats)


def table_order(passes: np.ndarray) -> np.ndarray:
    """Indices sorting pass rows into table order: by AOS, then satellite, then station.
    One sort on AOS; only the rows sharing an AOS (passes clipped at the window start,
    mostly) are ordered by the other keys."""
    aos = passes["aos_s"]
    # Not a stable sort: the rows sharing an AOS are ordered below by every key, and the
    # default sort is several times faster (SIMD).
    order = np.argsort(aos)
    ordered = aos[order]
    tie = np.flatnonzero(ordered[1:] == ordered[:-1])
    if tie.size:
        at = np.union1d(tie, tie + 1)
        rows = order[at]
        order[at] = rows[np.lexsort((passes["station"][rows], passes["sat"][rows],
                                     aos[rows]))]
    return order


def _block_job(satrecs, stations, start: datetime, end: datetime, min_el_deg, step_s: float,
               tol_s: float, memory_mb: float) -> _Job:
    window_s = (end - start).total_seconds()
    frames = geo.StationFrames.from_stations(stations, min_el_deg)
    jd0, fr0 = jday(start.year, start.month, start.day, start.hour, start.minute,
                    start.second + start.microsecond * 1e-6)
    return _Job(list(satrecs), frames, list(stations), jd0, fr0, window_s, geo.dut1_s(start),
                step_s, tol_s, {}, {}, memory_mb)


def _block_errors(job: _Job, names, start: datetime) -> list[SatError]:
    t0 = start.timestamp()
    return [SatError(s, names[s], code, SGP4_ERRORS.get(code, "error"), t0 + tau)
            for s, (tau, code) in sorted(job.errors.items())]


def _block_rows(job: _Job, start: datetime) -> Iterator[np.ndarray]:
    """The block's pass rows (POSIX times), in parts as the satellite chunks and station
    groups are refined; in no particular order."""
    stats, window_s, step_s, memory_mb = job.stats, job.window_s, job.step_s, job.memory_mb
    n_stations = len(job.stations)
    t0 = start.timestamp()
    grid = _GridClasses.of(job.satrecs, step_s)
    r_apo, ecc, screenable = grid.r_apo, grid.ecc, grid.screenable
    for ids in grid.groups():
        f_s, n = grid.fine_s[ids[0]].item(), grid.n_fact[ids[0]].item()
        k = max(1, math.ceil(window_s / (n * f_s)))
        size = _chunk_size(k + 1, k * n + 1, n_stations, memory_mb)
        for c0 in range(0, len(ids), size):
            chunk = ids[c0:c0 + size]
            stats["chunks"] = stats.get("chunks", 0) + 1
            for b in _run_chunk(job, chunk, n, f_s, r_apo[chunk], ecc[chunk],
                                screenable[chunk]):
                rows = _refine_station_chunk(job, b)
                rows = rows[(rows["los_s"] > rows["aos_s"]) | rows["aos_clipped"]]
                for key in ("aos_s", "tca_s", "los_s"):
                    rows[key] += t0
                yield rows


def merge_tables(tables: list[PassTable], names, stations, start, end) -> PassTable:
    """Concatenate tables of consecutive time blocks / satellite chunks; re-join passes cut at
    a block edge and keep the first error per satellite."""
    if len(tables) == 1 and tables[0].start == start and tables[0].end == end:
        t = tables[0]  # one error per satellite and no block edge: only the order to check
        passes = t.passes
        order = table_order(passes)
        if np.any(order[1:] < order[:-1]):
            passes = passes[order]
        return PassTable(passes, list(names), list(stations), start, end,
                         sorted(t.errors, key=lambda e: e.sat), dict(t.stats))
    passes = np.concatenate([t.passes for t in tables]) if tables else np.zeros(0, PASS_DTYPE)
    edges = {t.end.timestamp() for t in tables} - {end.timestamp()}
    if len(passes) > 1 and edges:
        passes = passes[np.lexsort((passes["aos_s"], passes["station"], passes["sat"]))]
        edge = np.isin(passes["los_s"], list(edges)) & passes["los_clipped"]
        join = (edge[:-1] & passes["aos_clipped"][1:]
                & (passes["aos_s"][1:] == passes["los_s"][:-1])
                & (passes["sat"][1:] == passes["sat"][:-1])
                & (passes["station"][1:] == passes["station"][:-1]))
        for i in np.flatnonzero(join)[::-1].tolist():
            a, b = passes[i], passes[i + 1]
            for key in ("los_s", "los_az_deg", "los_clipped"):
                a[key] = b[key]
            if b["max_el_deg"] > a["max_el_deg"]:
                for key in ("tca_s", "max_el_deg", "tca_az_deg"):
                    a[key] = b[key]
            a["sunlit"] |= b["sunlit"]
            a["visible"] |= b["visible"]
            passes[i] = a
        keep = np.ones(len(passes), bool)
        keep[np.flatnonzero(join) + 1] = False
        passes = passes[keep]
    passes = passes[table_order(passes)]
    first: dict[int, SatError] = {}
    stats: dict = {}
    for t in tables:
        for e in t.errors:
            if e.sat not in first or e.first_s < first[e.sat].first_s:
                first[e.sat] = e
        for k, val in t.stats.items():
            stats[k] = stats.get(k, 0) + val
    return PassTable(passes, list(names), list(stations), start, end,
                     [first[k] for k in sorted(first)], stats)


def time_blocks(start: datetime, end: datetime, block_days: float):
    """Consecutive [a, b) blocks covering the window, each at most ``block_days`` long."""
    if not (0.01 <= block_days <= 10.0):
        raise ConfigError(f"block_days = {block_days!r} is invalid; allowed: 0.01 to 10")
    start, end = _to_utc(start), _to_utc(end)
    if not end > start:
        raise ConfigError(f"the window end {end.isoformat()} must be after its start "
                          f"{start.isoformat()}")
    step = timedelta(days=block_days)
    out = []
    a = start
    while a < end:
        b = min(a + step, end)
        out.append((a, b))
        a = b
    return out


def remap(table: PassTable, ids, names, stations) -> PassTable:
    """A table computed on the satellite subset ``ids`` re-indexed to the full list."""
    ids = np.asarray(ids)
    passes = table.passes.copy()
    passes["sat"] = ids[passes["sat"]]
    errors = [SatError(int(ids[e.sat]), e.name, e.code, e.message, e.first_s)
              for e in table.errors]
    return PassTable(passes, list(names), list(stations), table.start, table.end, errors,
                     table.stats)


# Load model of the worker split, measured on the active catalogue: a satellite costs about
# sqrt(its fine step / the shortest fine step) of one with the shortest step (slower orbits
# have fewer samples and passes), every chunk about PIECE_COST of those however small it is.
# A grid class is dealt out over the workers from MIN_SPLIT_SATS per worker on.
PIECE_COST = 5.0
MIN_SPLIT_SATS = 16


def _worker_shares(grid: _GridClasses, workers: int) -> list[np.ndarray]:
    """Satellite indices per worker: each large grid class dealt out
    evenly, the small ones whole to the least-loaded worker (every chunk has a fixed cost, so
    small classes are not duplicated)."""
    weight = np.sqrt(grid.fine_s.min() / grid.fine_s)
    classes = grid.groups()
    costs = [float(weight[ids].sum()) + PIECE_COST for ids in classes]
    shares: list[list[np.ndarray]] = [[] for _ in range(workers)]
    load = np.zeros(workers)
    small = []
    for ids, cost in zip(classes, costs, strict=True):
        if len(ids) >= workers * MIN_SPLIT_SATS:
            for w in range(workers):
                shares[w].append(ids[w::workers])
                load[w] += cost / workers
        else:
            small.append((cost, ids))
    for cost, ids in sorted(small, key=lambda x: -x[0]):
        w = int(np.argmin(load))
        shares[w].append(ids)
        load[w] += cost
    return [np.sort(np.concatenate(s)) if s else np.zeros(0, np.int64) for s in shares]


def find_passes_batch(satrecs, names, stations, start: datetime, end: datetime,
                      min_el_deg: float | None = None, *, step_s: float = 480.0,
                      tol_s: float = 0.02, memory_mb: float = 256.0,
                      block_days: float = 7.0, workers: int = 1) -> PassTable:
    """Every pass of every satellite over every station in ``[start, end]``.

    ``satrecs``: sgp4 ``Satrec`` objects, ``names`` their names (same order); ``stations``:
    :class:`~tracker.station.Station` list; ``min_el_deg`` overrides each station's own
    minimum elevation (the horizon mask still applies). ``step_s`` is the fine sampling step,
    ``tol_s`` the time tolerance of AOS/TCA/LOS, ``memory_mb`` the working-set budget per
    process (the compiled kernels' own memory, :data:`kernels.COMPILED_RUNTIME_MB`, is
    counted in it when they run). ``workers > 1`` splits the satellites over forked
    processes (POSIX); the result is identical because every satellite is computed
    independently. For results too large to hold, :func:`iter_passes_batch` gives the same
    table in parts.
    """
    return PassTable.concat(list(_passes_in_parts(
        satrecs, names, stations, start, end, min_el_deg, step_s=step_s, tol_s=tol_s,
        memory_mb=memory_mb, block_days=block_days, workers=workers, spill=False)))


def iter_passes_batch(satrecs, names, stations, start: datetime, end: datetime,
                      min_el_deg: float | None = None, *, step_s: float = 480.0,
                      tol_s: float = 0.02, memory_mb: float = 256.0,
                      block_days: float = 7.0, workers: int = 1) -> Iterator[PassTable]:
    """:func:`find_passes_batch`'s table in consecutive parts, for results too large to hold
    (many stations, long windows): each part sorted like the whole, and concatenated they
    are the whole table. Memory stays within about ``memory_mb`` whatever the number of
    passes: while the search runs, passes beyond that budget wait in temporary files, one
    per span of AOS times, and each span is sorted when its part is given. The search is
    finished before the first part, so every part carries the run's ``errors`` and
    ``stats``."""
    yield from _passes_in_parts(satrecs, names, stations, start, end, min_el_deg,
                                step_s=step_s, tol_s=tol_s, memory_mb=memory_mb,
                                block_days=block_days, workers=workers, spill=True)


# Passes of one satellite over one station per day, a generous figure (low orbits give 4-6
# above 0 deg): the estimate that decides how a result is split for memory.
PASSES_PER_DAY = 8.0


def _passes_in_parts(satrecs, names, stations, start, end, min_el_deg, *, step_s, tol_s,
                     memory_mb, block_days, workers, spill: bool) -> Iterator[PassTable]:
    if len(satrecs) != len(names):
        raise ConfigError(f"{len(satrecs)} satellites but {len(names)} names")
    if not stations:
        raise ConfigError("no stations given")
    if not (10.0 <= step_s <= 600.0):
        raise ConfigError(f"step_s = {step_s!r} is invalid; allowed: 10 to 600 seconds")
    if not (math.isfinite(memory_mb) and memory_mb > 0.0):
        raise ConfigError(f"memory_mb = {memory_mb!r} is invalid; give a working-set budget "
                          f"in MB above 0")
    blocks = time_blocks(start, end, block_days)
    start, end = _to_utc(start), _to_utc(end)
    days = (end - start).total_seconds() / geo.DAY_S
    kernels.announce_work(len(satrecs) * len(stations) * days)
    # The budget is the process's: the compiled kernels' own memory leaves less for arrays.
    kwargs = dict(step_s=step_s, tol_s=tol_s,
                  memory_mb=max(memory_mb - kernels.runtime_mb(), memory_mb / 4))
    budget_rows = memory_mb * 2**20 / (4 * PASS_DTYPE.itemsize)
    est_rows = len(satrecs) * len(stations) * days * PASSES_PER_DAY
    errors: dict[int, SatError] = {}
    stats: dict = {}
    with RowSpill(PASS_DTYPE, "aos_s", start.timestamp(), end.timestamp(),
                  math.ceil(est_rows / budget_rows) if spill else 1,
                  rows_hint=min(est_rows, budget_rows)) as store:
        if workers <= 1 or len(satrecs) < 2 * workers:
            found = _local_rows(satrecs, names, stations, blocks, min_el_deg, kwargs, errors,
                                stats)
        else:
            found = _forked_rows(satrecs, names, stations, blocks, min_el_deg, kwargs, workers,
                                 max(1, math.ceil(est_rows / len(blocks) / budget_rows)),
                                 errors, stats)
        for rows in _joined(found, [b.timestamp() for _, b in blocks[:-1]],
                            len(stations)):
            store.add(rows)
        errs = [errors[k] for k in sorted(errors)]
        given = False
        for passes in store.spans():
            given = True
            yield PassTable(_sorted_in_place(passes), list(names), list(stations), start,
                            end, errs, stats)
        if not given:
            yield PassTable(np.zeros(0, PASS_DTYPE), list(names), list(stations), start, end,
                            errs, stats)


def _sorted_in_place(passes: np.ndarray) -> np.ndarray:
    """``passes`` put in table order (:func:`table_order`) in place
    (:func:`kernels.permute_rows`), so a large result never has a second copy of itself."""
    order = table_order(passes)
    if np.any(order[1:] < order[:-1]):
        kernels.permute_rows(passes, order)
    return passes


def _note_block(errors: dict, stats: dict, block_errors, block_stats: dict) -> None:
    """Keep the first error per satellite and add up the statistics of a finished block."""
    for e in block_errors:
        if e.sat not in errors or e.first_s < errors[e.sat].first_s:
            errors[e.sat] = e
    for k, val in block_stats.items():
        stats[k] = stats.get(k, 0) + val


def _local_rows(satrecs, names, stations, blocks, min_el_deg, kwargs, errors, stats):
    """(block index, rows) as each satellite chunk of each block is refined, in this
    process."""
    for i, (a, b) in enumerate(blocks):
        job = _block_job(satrecs, stations, a, b, min_el_deg, **kwargs)
        for rows in _block_rows(job, a):
            yield i, rows
        _note_block(errors, stats, _block_errors(job, names, a), job.stats)


_FORKED: tuple | None = None


def _forked_block(task):
    ids, a, b, kwargs = task
    satrecs, names, stations, min_el_deg = _FORKED  # type: ignore[misc]
    return ids, find_passes_block([satrecs[i] for i in ids], [names[i] for i in ids],
                                  stations, a, b, min_el_deg, **kwargs)


def _forked_rows(satrecs, names, stations, blocks, min_el_deg, kwargs, workers: int,
                 pieces: int, errors, stats):
    """(block index, rows) from ``workers`` forked processes, each block's satellites split
    into at least ``pieces`` tasks per worker so that one task's result fits the budget."""
    global _FORKED
    import multiprocessing

    shares = _worker_shares(_GridClasses.of(satrecs, kwargs["step_s"]), workers)
    parts = [x for p in range(pieces) for share in shares if len(x := share[p::pieces])]
    n_tasks = len(parts)
    tasks = [(sub, a, b, kwargs) for a, b in blocks for sub in parts]
    for a, _ in blocks:
        geo.dut1_s(a)  # computed once here, inherited by the forked workers
    _FORKED = (list(satrecs), list(names), list(stations), min_el_deg)
    try:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            for k, (sub, table) in enumerate(pool.imap(_forked_block, tasks)):
                table = remap(table, sub, names, stations)
                _note_block(errors, stats, table.errors, table.stats)
                yield k // n_tasks, table.passes
    finally:
        _FORKED = None


def _joined(found, edges: list[float], n_stations: int) -> Iterator[np.ndarray]:
    """The rows of consecutive time blocks with each pass cut at a block edge joined to its
    continuation (AOS of the first part, LOS of the last, the first highest maximum); a
    pass cut at an edge waits until the next block is finished."""
    empty = np.zeros(0, PASS_DTYPE)
    waiting, done = empty, np.zeros(0, bool)  # cut at the edge before the current block
    cut: list[np.ndarray] = []  # the current block's passes cut at its end
    block = 0
    for i, rows in found:
        while block < i:  # the block before is finished: what it did not continue is final
            yield waiting[~done]
            waiting = np.concatenate(cut) if cut else empty
            done, cut = np.zeros(len(waiting), bool), []
            block += 1
        if len(waiting):
            rows = _continue(waiting, done, rows, edges[i - 1], n_stations)
        if i < len(edges):
            at_end = rows["los_clipped"] & (rows["los_s"] == edges[i])
            cut.append(rows[at_end])
            rows = rows[~at_end]
        yield rows
    yield waiting[~done]
    yield from cut


def _continue(waiting, done, rows, edge_s: float, n_stations: int) -> np.ndarray:
    """``rows`` with each pass that continues a ``waiting`` one (cut at ``edge_s``) replaced
    by the joined pass; ``done`` marks the waiting passes so continued."""
    start = np.flatnonzero(rows["aos_clipped"] & (rows["aos_s"] == edge_s))
    wait = np.flatnonzero(~done)
    if not (start.size and wait.size):
        return rows

    def key(x):
        return x["sat"].astype(np.int64) * n_stations + x["station"]

    w_key = key(waiting[wait])
    order = np.argsort(w_key)
    at = np.clip(np.searchsorted(w_key[order], key(rows[start])), 0, len(wait) - 1)
    match = w_key[order][at] == key(rows[start])
    j, k = start[match], wait[order[at[match]]]
    a, b = waiting[k], rows[j]
    for name in ("los_s", "los_az_deg", "los_clipped"):
        a[name] = b[name]
    higher = b["max_el_deg"] > a["max_el_deg"]
    for name in ("tca_s", "max_el_deg", "tca_az_deg"):
        a[name] = np.where(higher, b[name], a[name])
    a["sunlit"] |= b["sunlit"]
    a["visible"] |= b["visible"]
    rows = rows.copy()
    rows[j] = a
    done[k] = True
    return rows
