"""The batch finder's hot loops, each behind one name with two implementations of the same
arithmetic: numpy (the reference, always there) and a compiled loop (numba, the optional
``fast`` extra) that passes over the data once without temporaries.

numba is loaded only for jobs big enough to pay for it (:func:`backend`); how it is loaded
and selected (``TRACKER_NUMBA=0``, :func:`tracker.compiled.use`) is :mod:`tracker.compiled`'s.

The two implementations agree to rounding: the screen (:func:`fine_screen`) runs in float32
with numpy and in float64 compiled (the cone it tests has degrees of margin, so both keep
every step a pass can be in); the root solver (:func:`solve_cubic`) takes the same Newton and
bisection steps, per bracket, in both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracker import compiled
from tracker.batch import geometry as geo
from tracker.sun import EARTH_RADIUS_KM

EARTH_ROTATION_RAD_S = geo.EARTH_ROTATION_RAD_S

_worth_compiling = False  # a job big enough to pay numba's fixed cost was announced

# Loading numba and the cached kernels costs about 0.7 s CPU once per process (compiling them
# the first time, about 5 s); the kernels save about 20 us per satellite-station-day at one
# station (less at many): from this much work on, the fixed cost is paid back.
COMPILED_MIN_WORK = 30_000.0
# Resident memory the compiled kernels bring into a process: numba, LLVM and the machine
# code of the loops (measured: 43 MB for numpy, sgp4 and skyfield, 194 MB once the kernels
# have run). The finder counts it against its memory budget when they run.
COMPILED_RUNTIME_MB = 150.0


def announce_work(sat_station_days: float) -> None:
    """Tell the automatic choice how big a job is starting (satellites x stations x days):
    from :data:`COMPILED_MIN_WORK` on, the compiled kernels are used from then on in this
    process."""
    global _worth_compiling
    if sat_station_days >= COMPILED_MIN_WORK:
        _worth_compiling = True


def backend() -> str:
    """The implementation the kernels run (:func:`tracker.compiled.backend`; loading numba
    is worth it once a big enough job was announced by :func:`announce_work`)."""
    return compiled.backend(_worth_compiling)


def runtime_mb() -> float:
    """The resident memory (MB) the kernels' implementation holds in this process besides
    the data: :data:`COMPILED_RUNTIME_MB` for the compiled kernels, 0 for numpy's."""
    return COMPILED_RUNTIME_MB if backend() == "numba" else 0.0


# The compiled loops; the functions they call are compiled (in place of the Python ones,
# which only the loops use) before the first loop is.
_jit = compiled.Loops(globals(), helpers=(
    "_el_rate_at", "_sin_el_newton", "_bracket_step", "_rates", "_sub_arc_trig",
    "_look_and_f"))


# --- fine screening -------------------------------------------------------------------------

def sub_arcs(phi, ecc, n: int, coarse_s: float):
    """Bounds [a1, a2] (rad from the arc's start, (len(phi), n), float32) of the sub-arc each
    of the ``n`` fine steps of coarse arcs of angle ``phi`` can sweep, for orbits of
    eccentricity ``ecc``. float32: the cone has degrees of margin, float32 rounds at 1e-7
    rad."""
    f32 = np.float32
    fine_s = coarse_s / n
    e_eff = np.minimum(ecc + 0.002, 0.9)
    ratio = ((1.0 + e_eff) / (1.0 - e_eff)) ** 2 * 1.01
    w_mean = phi / coarse_s
    w_lo, w_hi = (w_mean / ratio).astype(f32)[:, None], (w_mean * ratio).astype(f32)[:, None]
    t_a = (np.arange(n) * fine_s).astype(f32)
    t_b = (np.arange(1, n + 1) * fine_s).astype(f32)
    ph_ = phi.astype(f32)[:, None]
    a1 = np.maximum(w_lo * t_a, ph_ - w_hi * (f32(coarse_s) - t_a))
    np.clip(a1, f32(0.0), ph_, out=a1)
    a2 = np.minimum(w_hi * t_b, ph_ - w_lo * (f32(coarse_s) - t_b))
    np.clip(a2, a1, ph_, out=a2)
    return a1, a2


def subarc_within(pa, pq, a1, a2, cos_lim):
    """Does the sub-arc [a1, a2] (angles from A in the orbit plane, 0 <= a2 - a1 < 2 pi) come
    within the cone around the station, i.e. does the station's largest projection on it,
    max over a of pa cos a + pq sin a, reach ``cos_lim``? (Inputs are overwritten.)

    The station's in-plane part is R (cos beta, sin beta). On the arc's middle direction m
    (half-width w) it projects to pm = R cos(beta - m), across it to |pp| = R |sin(beta - m)|.
    Inside the arc (|beta - m| <= w, i.e. pm >= R cos w) the largest projection is R; outside
    it is at the nearer end, R cos(|beta - m| - w) = pm cos w + |pp| sin w. No arctangent.
    """
    r_in = np.sqrt(pa * pa + pq * pq)
    mid = a1 + a2
    mid *= 0.5
    half = a2 - a1
    half *= 0.5
    cm, sm, ch, sh = np.cos(mid), np.sin(mid), np.cos(half), np.sin(half)
    pm = pa * cm
    pm += pq * sm
    pq *= cm
    pa *= sm
    pp = np.abs(pq - pa, out=pq)
    pp *= sh
    pp += pm * ch
    sub = pp >= cos_lim
    ch *= r_in
    sub |= (pm >= ch) & (r_in >= cos_lim)
    return sub


@dataclass(frozen=True)
class StationTrack:
    """One station's geocentric unit vector in TEME at the middle of every fine step of the
    window: rho (cos psi, sin psi), z, with psi = GMST + longitude (float64, (K * n,))."""

    psi: np.ndarray
    rho: float
    z: float


@dataclass(frozen=True)
class SharedArcs:
    """The station-independent part of the fine screen, computed once for the candidate
    coarse intervals of every station (:func:`shared_arcs`): per interval (row) and fine
    step, the sub-arc bounds (numpy: ``a1``, ``a2``, float32) or the cosine and sine of
    its middle and of its half-width (compiled: ``trig``, float64, the loop's own values);
    ``kind`` is the implementation that made it."""

    kind: str
    a1: np.ndarray
    a2: np.ndarray
    trig: np.ndarray


def shared_arcs(phi, ss, kk, ecc, n: int, coarse_s: float) -> SharedArcs:
    """:class:`SharedArcs` of the coarse intervals (``ss``, ``kk``) (their rows in that
    order) for :func:`fine_screen` at many stations: its trigonometry then runs once per
    interval, not once per station."""
    kind = backend()
    if kind == "numba":
        trig = np.empty((len(kk), n, 4))
        _jit("_arc_trig_loop")(phi, ss, kk, ecc, n, coarse_s, trig)
        return SharedArcs(kind, np.zeros((0, n), np.float32), np.zeros((0, n), np.float32),
                          trig)
    a1, a2 = sub_arcs(phi[ss, kk], ecc[ss], n, coarse_s)
    return SharedArcs(kind, a1, a2, np.zeros((0, n, 4)))


def fine_screen(A, q, phi, ss, kk, ecc, n: int, coarse_s: float, track: StationTrack,
                cos_lim, screenable, arcs: SharedArcs | None = None, rows=None):
    """(C, n) booleans: the fine steps of the C candidate coarse intervals (``ss``, ``kk``)
    whose sub-arc comes within the station's cone. ``A``, ``q`` (S, K, 3): in-plane axes,
    ``phi`` (S, K): arc angles of every coarse interval; per satellite (S,): eccentricity,
    cone cosine and ``screenable``. ``arcs``: :func:`shared_arcs` already computed for
    many stations, ``rows`` the row of each candidate in it (same decisions as without)."""
    if arcs is not None and arcs.kind != backend():
        arcs = None
    if backend() == "numba":
        out = np.empty((len(kk), n), np.bool_)
        trig, at = ((np.zeros((0, n, 4)), np.zeros(0, np.int64)) if arcs is None
                    else (arcs.trig, np.asarray(rows, np.int64)))
        _jit("_fine_screen_loop")(A, q, phi, ss, kk, ecc, n, coarse_s, track.psi, track.rho,
                                  track.z, cos_lim, screenable, trig, at, out)
        return out
    f32 = np.float32
    if arcs is None:
        a1, a2 = sub_arcs(phi[ss, kk], ecc[ss], n, coarse_s)
    else:
        a1, a2 = arcs.a1[rows], arcs.a2[rows]
    K = len(track.psi) // n
    cp = (np.cos(track.psi) * track.rho).astype(f32).reshape(K, n)[kk]
    sp = (np.sin(track.psi) * track.rho).astype(f32).reshape(K, n)[kk]
    A, q = A[ss, kk].astype(f32), q[ss, kk].astype(f32)
    pa = A[:, 0, None] * cp
    pa += A[:, 1, None] * sp
    pa += A[:, 2, None] * f32(track.z)
    pq = q[:, 0, None] * cp
    pq += q[:, 1, None] * sp
    pq += q[:, 2, None] * f32(track.z)
    sub = subarc_within(pa, pq, a1, a2, cos_lim[ss].astype(f32)[:, None])
    sub |= ~screenable[ss][:, None]
    return sub


def _rates(ph, ecc, coarse_s):  # pragma: no cover - compiled by numba (sub_arcs' rates)
    """Slowest and fastest angular rate along a coarse arc of angle ``ph``."""
    e_eff = min(ecc + 0.002, 0.9)
    ratio = ((1.0 + e_eff) / (1.0 - e_eff)) ** 2 * 1.01
    w_mean = ph / coarse_s
    return w_mean / ratio, w_mean * ratio


def _sub_arc_trig(ph, w_lo, w_hi, i, fine_s, coarse_s
                  ):  # pragma: no cover - compiled by numba (one sub-arc of sub_arcs)
    """cos and sin of the middle and of the half-width of fine step ``i``'s sub-arc."""
    t_a = i * fine_s
    t_b = t_a + fine_s
    a1 = min(max(max(w_lo * t_a, ph - w_hi * (coarse_s - t_a)), 0.0), ph)
    a2 = min(max(min(w_hi * t_b, ph - w_lo * (coarse_s - t_b)), a1), ph)
    mid = 0.5 * (a1 + a2)
    half = 0.5 * (a2 - a1)
    return math.cos(mid), math.sin(mid), math.cos(half), math.sin(half)


def _arc_trig_loop(phi, ss, kk, ecc, n, coarse_s, out
                   ):  # pragma: no cover - compiled by numba (shared_arcs' twin)
    fine_s = coarse_s / n
    for c in range(len(kk)):
        ph = phi[ss[c], kk[c]]
        w_lo, w_hi = _rates(ph, ecc[ss[c]], coarse_s)
        for i in range(n):
            out[c, i, 0], out[c, i, 1], out[c, i, 2], out[c, i, 3] = _sub_arc_trig(
                ph, w_lo, w_hi, i, fine_s, coarse_s)


def _fine_screen_loop(A, q, phi, ss, kk, ecc, n, coarse_s, psi, rho, z, cos_lim, screenable,
                      trig, rows, out):  # pragma: no cover - compiled by numba (its twin)
    fine_s = coarse_s / n
    shared = len(rows) > 0
    cps = np.empty(len(psi))
    sps = np.empty(len(psi))
    for j in range(len(psi)):
        cps[j] = math.cos(psi[j]) * rho
        sps[j] = math.sin(psi[j]) * rho
    for c in range(len(kk)):
        si, ki = ss[c], kk[c]
        if not screenable[si]:
            out[c, :] = True
            continue
        ph = phi[si, ki]
        w_lo, w_hi = _rates(ph, ecc[si], coarse_s)
        lim = cos_lim[si]
        a0x, a0y, a0z = A[si, ki, 0], A[si, ki, 1], A[si, ki, 2] * z
        q0x, q0y, q0z = q[si, ki, 0], q[si, ki, 1], q[si, ki, 2] * z
        base = ki * n
        for i in range(n):
            if shared:
                row = rows[c]
                cm, sm = trig[row, i, 0], trig[row, i, 1]
                ch, sh = trig[row, i, 2], trig[row, i, 3]
            else:
                cm, sm, ch, sh = _sub_arc_trig(ph, w_lo, w_hi, i, fine_s, coarse_s)
            cp, sp = cps[base + i], sps[base + i]
            pa = a0x * cp + a0y * sp + a0z
            pq = q0x * cp + q0y * sp + q0z
            pm = pa * cm + pq * sm
            if abs(pq * cm - pa * sm) * sh + pm * ch >= lim:
                out[c, i] = True
            else:
                r_in = math.sqrt(pa * pa + pq * pq)
                out[c, i] = pm >= ch * r_in and r_in >= lim


# --- first guesses from the samples ---------------------------------------------------------

def hermite_root(f0, d0, f1, d1, h, slope: bool = False, n: int = 17):
    """Where (fraction 0..1 of each interval) the cubic Hermite through values ``f0``, ``f1``
    and rates ``d0``, ``d1`` at the ends of intervals ``h`` long first changes sign (its
    slope, with ``slope``): the linear root between the first two of ``n`` samples across
    the interval that differ in sign (the middle sample pair when none do)."""
    s = np.linspace(0.0, 1.0, n)
    if slope:
        basis = np.stack([s * 0.0, s**2, s])
    else:
        basis = np.stack([2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2,
                          s**3 - s**2])
    if backend() == "numba":
        out = np.empty(len(f0))
        _jit("_hermite_root_loop")(f0, d0, f1, d1, np.broadcast_to(h, np.shape(f0)), slope,
                                   basis, s, out)
        return out
    if slope:
        c1 = h * d0
        c2 = -3 * f0 - 2 * h * d0 + 3 * f1 - h * d1
        c3 = 2 * f0 + h * d0 - 2 * f1 + h * d1
        p = 3 * c3[:, None] * basis[1] + 2 * c2[:, None] * s + c1[:, None]
    else:
        p = (f0[:, None] * basis[0] + (h * d0)[:, None] * basis[1] + f1[:, None] * basis[2]
             + (h * d1)[:, None] * basis[3])
    neg = p < 0
    change = neg[:, 1:] != neg[:, :-1]
    k = np.where(change.any(1), change.argmax(1), n // 2 - 1)
    rows = np.arange(len(p))
    a, b = p[rows, k], p[rows, k + 1]
    frac = np.where(b != a, a / np.where(b != a, a - b, 1.0), 0.5)
    return s[k] + np.clip(frac, 0.0, 1.0) * (s[k + 1] - s[k])


def _hermite_root_loop(f0, d0, f1, d1, h, slope, basis, s, out
                       ):  # pragma: no cover - compiled by numba (hermite_root's twin)
    n = len(s)
    p = np.empty(n)
    for i in range(len(f0)):
        c1 = c2 = c3 = 0.0
        if slope:
            c1 = h[i] * d0[i]
            c2 = -3 * f0[i] - 2 * h[i] * d0[i] + 3 * f1[i] - h[i] * d1[i]
            c3 = 2 * f0[i] + h[i] * d0[i] - 2 * f1[i] + h[i] * d1[i]
        k = n // 2 - 1
        for m in range(n):
            if slope:
                p[m] = 3 * c3 * basis[1, m] + 2 * c2 * s[m] + c1
            else:
                p[m] = (f0[i] * basis[0, m] + (h[i] * d0[i]) * basis[1, m]
                        + f1[i] * basis[2, m] + (h[i] * d1[i]) * basis[3, m])
            if m > 0 and (p[m] < 0) != (p[m - 1] < 0):
                k = m - 1
                break
        a, b = p[k], p[k + 1]
        frac = a / (a - b) if b != a else 0.5
        if frac < 0.0:
            frac = 0.0
        elif frac > 1.0:
            frac = 1.0
        out[i] = s[k] + frac * (s[k + 1] - s[k])


# --- refinement on the cubic interpolant ----------------------------------------------------

@dataclass(frozen=True)
class Cubic:
    """The cubic Hermite interpolant of the TEME orbit over fine steps of ``h`` seconds, one
    per bracket k, starting at ``t0[k]``: r(s) = ((c3 s + c2) s + c1) s + r0, s = (tau - t0)
    / h; plus an optional first-order correction (``x_ref``, ``dr``, ``dv``: SGP4 - cubic at
    ``x_ref``) that is zero until set.

    Through the SGP4 positions and velocities at both ends of the step it is accurate to
    ~1 km for LEO at 480 s (error ~ (omega h)^4 r / 384) and as good for slower orbits,
    whose steps scale with the period (no SGP4 calls)."""

    t0: np.ndarray
    h: float
    r0: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    c3: np.ndarray
    x_ref: np.ndarray
    dr: np.ndarray
    dv: np.ndarray

    @classmethod
    def through(cls, t0, h: float, r0, v0, r1, v1) -> Cubic:
        d = r1 - r0
        n = len(t0)
        return cls(t0, h, r0, h * v0, 3 * d - h * (2 * v0 + v1), h * (v0 + v1) - 2 * d,
                   np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3)))

    @classmethod
    def between(cls, tau, h: float, r, v, idx) -> Cubic:
        """:meth:`through` the samples ``idx`` and ``idx + 1`` of TEME states ``r``, ``v``
        (n, 3) at times ``tau`` (compiled: one pass, no gathered copies; same arithmetic)."""
        if backend() != "numba":
            return cls.through(tau[idx], h, r.take(idx, 0), v.take(idx, 0),
                               r.take(idx + 1, 0), v.take(idx + 1, 0))
        n = len(idx)
        r0, c1, c2, c3 = (np.empty((n, 3)) for _ in range(4))
        _jit("_cubic_between_loop")(h, r, v, idx, r0, c1, c2, c3)
        return cls(tau[idx], h, r0, c1, c2, c3, np.zeros(n), np.zeros((n, 3)),
                   np.zeros((n, 3)))

    def __call__(self, k, tau):
        """(r, v, a) of the uncorrected cubic of brackets ``k`` at times ``tau``."""
        h = self.h
        s = ((tau - self.t0[k]) / h)[:, None]
        a0, a1, a2, a3 = self.r0[k], self.c1[k], self.c2[k], self.c3[k]
        r = ((a3 * s + a2) * s + a1) * s + a0
        v = ((3 * a3 * s + 2 * a2) * s + a1) / h
        a = (6 * a3 * s + 2 * a2) / (h * h)
        return r, v, a

    def corrected(self, k, tau):
        """Like calling it, with the correction added to r and v."""
        r, v, a = self(k, tau)
        r = r + self.dr[k] + self.dv[k] * (tau - self.x_ref[k])[:, None]
        return r, v + self.dv[k], a


def _cubic_between_loop(h, r, v, idx, r0, c1, c2, c3
                        ):  # pragma: no cover - compiled by numba (Cubic.through's twin)
    for j in range(len(idx)):
        i = idx[j]
        for c in range(3):
            a, b = r[i, c], r[i + 1, c]
            v0, v1 = v[i, c], v[i + 1, c]
            d = b - a
            r0[j, c] = a
            c1[j, c] = h * v0
            c2[j, c] = 3 * d - h * (2 * v0 + v1)
            c3[j, c] = h * (v0 + v1) - 2 * d


@dataclass(frozen=True)
class Sky:
    """What turns TEME states into look angles: GMST theta0 + rate * tau (rad), station ECEF
    positions and up, east, north unit vectors (N, 3), sin(min elevation) per station."""

    theta0: float
    theta_rate: float
    ecef_km: np.ndarray
    up: np.ndarray
    east: np.ndarray
    north: np.ndarray
    sin_min_el: np.ndarray


@dataclass
class Topo:
    """sin(elevation) and its first two time derivatives (per second) at TEME states."""

    s: np.ndarray
    s1: np.ndarray
    s2: np.ndarray | None
    d: tuple  # station -> satellite vector, TEME components
    c: np.ndarray  # cos/sin of the GMST angle (for azimuths)
    sn: np.ndarray

    def el_deg(self):
        return np.degrees(np.arcsin(np.clip(self.s, -1.0, 1.0)))

    def take(self, i) -> Topo:
        return Topo(self.s[i], self.s1[i], None if self.s2 is None else self.s2[i],
                    tuple(x[i] for x in self.d), self.c[i], self.sn[i])

    def az_deg(self, sky: Sky, st):
        c, sn = self.c, self.sn
        e, n = geo.station_columns(sky.east, st), geo.station_columns(sky.north, st)
        dx, dy, dz = self.d
        # The station's east/north axes rotated into TEME.
        de = dx * (c * e[0] - sn * e[1]) + dy * (sn * e[0] + c * e[1])
        dn = (dx * (c * n[0] - sn * n[1]) + dy * (sn * n[0] + c * n[1]) + dz * n[2])
        return np.degrees(np.arctan2(de, dn)) % 360.0


def topo(sky: Sky, st, tau, r, v, a=None) -> Topo:
    """sin(el), d/dt and (given the acceleration ``a``) d2/dt2 of stations ``st`` (one per
    state) at TEME states (n, 3); the station turns with the Earth in TEME. sin(el) is
    smooth everywhere (even through the zenith), so its derivative's root is the culmination
    and needs no arcsin."""
    theta = sky.theta0 + sky.theta_rate * np.asarray(tau, dtype=float)
    c, sn = np.cos(theta), np.sin(theta)
    w = EARTH_ROTATION_RAD_S
    o, u = geo.station_columns(sky.ecef_km, st), geo.station_columns(sky.up, st)
    ox, oy = c * o[0] - sn * o[1], sn * o[0] + c * o[1]
    ux, uy, uz = c * u[0] - sn * u[1], sn * u[0] + c * u[1], u[2]
    dx, dy, dz = r[:, 0] - ox, r[:, 1] - oy, r[:, 2] - o[2]
    vx, vy, vz = v[:, 0] + w * oy, v[:, 1] - w * ox, v[:, 2]  # relative velocity
    inv = 1.0 / np.sqrt(dx * dx + dy * dy + dz * dz)
    s = (dx * ux + dy * uy + dz * uz) * inv
    ru1 = vx * ux + vy * uy + vz * uz + w * (dy * ux - dx * uy)
    dist1 = (dx * vx + dy * vy + dz * vz) * inv
    s1 = (ru1 - s * dist1) * inv
    s2 = None
    if a is not None:
        w2 = w * w
        ax, ay, az = a[:, 0] + w2 * ox, a[:, 1] + w2 * oy, a[:, 2]
        ru2 = (ax * ux + ay * uy + az * uz + 2 * w * (vy * ux - vx * uy)
               - w2 * (dx * ux + dy * uy))
        dist2 = (vx * vx + vy * vy + vz * vz + dx * ax + dy * ay + dz * az
                 - dist1 * dist1) * inv
        s2 = (ru2 - 2 * s1 * dist1 - s * dist2) * inv
    return Topo(s, s1, s2, (dx, dy, dz), c, sn)


def newton_sin_el(s, s1, s2, sin_min, tca: bool):
    """(g, Newton step to g's root): g = d sin(el)/dt for a culmination, else sin(el) -
    ``sin_min`` with a second-order step (sin(el) is curved on the scale of a grazing
    pass)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if tca:
            return s1, s1 / s2
        g = s - sin_min
        step = g / s1
        return g, step + 0.5 * s2 * step * step / s1


def bracketed(x, step, g, lo, hi, lo_neg):
    """The bracket narrowed by the sign of g at x, and the Newton point x - step in it
    (bisection when the step leaves it)."""
    same_as_lo = (g < 0) == lo_neg
    lo = np.where(same_as_lo, x, lo)
    hi = np.where(same_as_lo, hi, x)
    x_new = x - step
    bad = ~np.isfinite(x_new) | (x_new <= lo) | (x_new >= hi)
    return np.where(bad, 0.5 * (lo + hi), x_new), lo, hi


def solve(evaluate, lo, hi, lo_neg, guess, tol_s: float, max_it: int = 60):
    """Root of g in each bracket [lo, hi] (g changes sign there; ``lo_neg``: g(lo) < 0), all
    brackets at once: Newton steps (``evaluate(k, tau) -> (g, step)``), bisection when a
    step leaves the bracket. Stops when a step is below ``tol_s``; returns the point after
    that last step (not evaluated; quadratically closer than the step)."""
    tau = np.clip(guess, lo, hi)
    lo, hi = lo.copy(), hi.copy()
    active = np.arange(len(lo))
    for _ in range(max_it):
        if active.size == 0:
            break
        x = tau[active]
        g, step = evaluate(active, x)
        x_new, lo[active], hi[active] = bracketed(x, step, g, lo[active], hi[active],
                                                  lo_neg[active])
        tau[active] = x_new
        done = (np.abs(x_new - x) < tol_s) | (hi[active] - lo[active] < tol_s) | (g == 0)
        active = active[~done]
    return tau


def solve_cubic(sky: Sky, cubic: Cubic, k, st, lo, hi, lo_neg, guess, tol_s: float,
                tca: bool, max_it: int = 60):
    """:func:`solve` for culminations (``tca``) or AOS/LOS of stations ``st`` without a horizon
    mask on the (corrected) cubic of brackets ``k``: the roots of d sin(el)/dt, or of
    sin(el) - sin(min el)."""
    if backend() == "numba":
        tau = np.empty(len(lo))
        _jit("_solve_cubic_loop")(
            sky.theta0, sky.theta_rate, sky.ecef_km, sky.up, sky.sin_min_el, cubic.t0,
            cubic.h, cubic.r0, cubic.c1, cubic.c2, cubic.c3, cubic.x_ref, cubic.dr, cubic.dv,
            k, st, lo, hi, lo_neg, guess, tol_s, tca, max_it, tau)
        return tau

    def evaluate(j, tau):
        kj = k[j]
        r, v, a = cubic.corrected(kj, tau)
        t = topo(sky, st[j], tau, r, v, a)
        return newton_sin_el(t.s, t.s1, t.s2, sky.sin_min_el[st[j]], tca)

    return solve(evaluate, lo, hi, lo_neg, guess, tol_s, max_it)


def _solve_cubic_loop(theta0, theta_rate, ecef, up, sin_min_el, t0, h, r0, c1, c2, c3, x_ref,
                      dr, dv, k, st, lo_in, hi_in, lo_neg, guess, tol_s, tca, max_it,
                      out):  # pragma: no cover - compiled by numba (solve_cubic's twin)
    for j in range(len(lo_in)):
        b, m = k[j], st[j]
        lo, hi = lo_in[j], hi_in[j]
        tau = min(max(guess[j], lo), hi)
        for _ in range(max_it):
            x = tau
            # The cubic and its correction at x, per component.
            s_ = (x - t0[b]) / h
            dt = x - x_ref[b]
            hh = h * h
            rx = ((c3[b, 0] * s_ + c2[b, 0]) * s_ + c1[b, 0]) * s_ + r0[b, 0]
            rx = rx + dr[b, 0] + dv[b, 0] * dt
            ry = ((c3[b, 1] * s_ + c2[b, 1]) * s_ + c1[b, 1]) * s_ + r0[b, 1]
            ry = ry + dr[b, 1] + dv[b, 1] * dt
            rz = ((c3[b, 2] * s_ + c2[b, 2]) * s_ + c1[b, 2]) * s_ + r0[b, 2]
            rz = rz + dr[b, 2] + dv[b, 2] * dt
            qx = ((3 * c3[b, 0] * s_ + 2 * c2[b, 0]) * s_ + c1[b, 0]) / h + dv[b, 0]
            qy = ((3 * c3[b, 1] * s_ + 2 * c2[b, 1]) * s_ + c1[b, 1]) / h + dv[b, 1]
            qz = ((3 * c3[b, 2] * s_ + 2 * c2[b, 2]) * s_ + c1[b, 2]) / h + dv[b, 2]
            gx = (6 * c3[b, 0] * s_ + 2 * c2[b, 0]) / hh
            gy = (6 * c3[b, 1] * s_ + 2 * c2[b, 1]) / hh
            gz = (6 * c3[b, 2] * s_ + 2 * c2[b, 2]) / hh
            g, step, _s, _dx, _dy, _dz, _c, _sn = _sin_el_newton(
                theta0, theta_rate, ecef, up, sin_min_el, m, x, (rx, ry, rz), (qx, qy, qz),
                (gx, gy, gz), tca)
            if (g < 0) == lo_neg[j]:
                lo = x
            else:
                hi = x
            x_new = x - step
            if not math.isfinite(x_new) or x_new <= lo or x_new >= hi:
                x_new = 0.5 * (lo + hi)
            tau = x_new
            if abs(x_new - x) < tol_s or hi - lo < tol_s or g == 0:
                break
        out[j] = tau


# --- correction from SGP4's state ------------------------------------------------------------

def correct(sky: Sky, idx, xa, r_s, v_s, a_s, st, lo, hi, lo_neg, tol_s: float, span_s: float,
            tca: bool, out: tuple, newton=None):
    """Newton steps of brackets ``idx`` from SGP4's state (``r_s``, ``v_s``, two-body
    acceleration ``a_s``) at ``xa``, on its Taylor series, while they stay within ``span_s``
    of ``xa`` (at most 4 after the first); each evaluated point's time, elevation, azimuth
    and position go to ``out`` = (tau, el, az, r) at the bracket, ``lo``/``hi`` narrow in
    place. Returns the point after the last step per bracket and whether it left the span
    (then the Taylor series no longer holds). ``newton(st, Topo) -> (g, step)`` replaces
    :func:`newton_sin_el` where stations have horizon masks (numpy only)."""
    if newton is None and backend() == "numba":
        x1, far = np.empty(len(idx)), np.empty(len(idx), np.bool_)
        _jit("_correct_loop")(sky.theta0, sky.theta_rate, sky.ecef_km, sky.up, sky.east,
                              sky.north, sky.sin_min_el, idx, xa, r_s, v_s, a_s, st, lo, hi,
                              lo_neg, tol_s, span_s, tca, *out, x1, far)
        return x1, far
    if newton is None:
        def newton(st_k, t):
            return newton_sin_el(t.s, t.s1, t.s2, sky.sin_min_el[st_k], tca)
    tau, el, az, r_out = out
    st_a = st[idx]
    g, step = newton(st_a, topo(sky, st_a, xa, r_s, v_s, a_s))
    x1, lo[idx], hi[idx] = bracketed(xa, step, g, lo[idx], hi[idx], lo_neg[idx])
    near = np.flatnonzero(np.abs(x1 - xa) <= span_s)
    far = np.abs(x1 - xa) > span_s
    for _it in range(4):
        if near.size == 0:
            break
        k = idx[near]
        dt = (x1[near] - xa[near])[:, None]
        a_n = a_s[near]
        r1 = r_s[near] + (v_s[near] + 0.5 * a_n * dt) * dt
        t1 = topo(sky, st[k], x1[near], r1, v_s[near] + a_n * dt, a_n)
        tau[k], r_out[k] = x1[near], r1
        el[k], az[k] = t1.el_deg(), t1.az_deg(sky, st[k])
        g1, step1 = newton(st[k], t1)
        x2, lo[k], hi[k] = bracketed(x1[near], step1, g1, lo[k], hi[k], lo_neg[k])
        more = ~(np.abs(step1) <= tol_s) & (g1 != 0) & (hi[k] - lo[k] >= tol_s)
        x1[near] = x2
        leave = more & (np.abs(x2 - xa[near]) > span_s)
        far[near[leave]] = True
        near = near[more & ~leave]
    return x1, far


def _sin_el_newton(theta0, theta_rate, ecef, up, sin_min, m, x, r, v, a, tca
                   ):  # pragma: no cover - compiled by numba (topo + newton_sin_el)
    """(g, step, s, dx, dy, dz, c, sn) of station ``m`` at time ``x`` and TEME state r, v, a
    (3-tuples): :func:`topo` and :func:`newton_sin_el` for one point."""
    w = EARTH_ROTATION_RAD_S
    w2 = w * w
    theta = theta0 + theta_rate * x
    c, sn = math.cos(theta), math.sin(theta)
    ox, oy = c * ecef[m, 0] - sn * ecef[m, 1], sn * ecef[m, 0] + c * ecef[m, 1]
    oz = ecef[m, 2]
    ux, uy, uz = c * up[m, 0] - sn * up[m, 1], sn * up[m, 0] + c * up[m, 1], up[m, 2]
    dx, dy, dz = r[0] - ox, r[1] - oy, r[2] - oz
    vx, vy, vz = v[0] + w * oy, v[1] - w * ox, v[2]
    inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
    s = (dx * ux + dy * uy + dz * uz) * inv
    ru1 = vx * ux + vy * uy + vz * uz + w * (dy * ux - dx * uy)
    dist1 = (dx * vx + dy * vy + dz * vz) * inv
    s1 = (ru1 - s * dist1) * inv
    ax, ay, az = a[0] + w2 * ox, a[1] + w2 * oy, a[2]
    ru2 = (ax * ux + ay * uy + az * uz + 2 * w * (vy * ux - vx * uy)
           - w2 * (dx * ux + dy * uy))
    dist2 = (vx * vx + vy * vy + vz * vz + dx * ax + dy * ay + dz * az
             - dist1 * dist1) * inv
    s2 = (ru2 - 2 * s1 * dist1 - s * dist2) * inv
    if tca:
        g = s1
        step = s1 / s2
    else:
        g = s - sin_min[m]
        step = g / s1
        step = step + 0.5 * s2 * step * step / s1
    return g, step, s, dx, dy, dz, c, sn


def _correct_loop(theta0, theta_rate, ecef, up, east, north, sin_min, idx, xa, r_s, v_s, a_s,
                  st, lo, hi, lo_neg, tol_s, span_s, tca, tau, el, az, r_out, x1_out, far_out
                  ):  # pragma: no cover - compiled by numba (correct's twin)
    deg = 180.0 / math.pi
    for j in range(len(idx)):
        b = idx[j]
        m = st[b]
        x0 = xa[j]
        r = (r_s[j, 0], r_s[j, 1], r_s[j, 2])
        v = (v_s[j, 0], v_s[j, 1], v_s[j, 2])
        a = (a_s[j, 0], a_s[j, 1], a_s[j, 2])
        g, step, s, dx, dy, dz, c, sn = _sin_el_newton(theta0, theta_rate, ecef, up, sin_min,
                                                       m, x0, r, v, a, tca)
        x1 = _bracket_step(x0, step, g, lo, hi, lo_neg, b)
        far = abs(x1 - x0) > span_s
        if not far:
            look = (s, dx, dy, dz, c, sn)
            for _it in range(4):
                dt = x1 - x0
                r1 = (r[0] + (v[0] + 0.5 * a[0] * dt) * dt,
                      r[1] + (v[1] + 0.5 * a[1] * dt) * dt,
                      r[2] + (v[2] + 0.5 * a[2] * dt) * dt)
                v1 = (v[0] + a[0] * dt, v[1] + a[1] * dt, v[2] + a[2] * dt)
                g1, step1, s, dx, dy, dz, c, sn = _sin_el_newton(
                    theta0, theta_rate, ecef, up, sin_min, m, x1, r1, v1, a, tca)
                tau[b] = x1
                r_out[b, 0], r_out[b, 1], r_out[b, 2] = r1
                look = (s, dx, dy, dz, c, sn)
                x2 = _bracket_step(x1, step1, g1, lo, hi, lo_neg, b)
                more = not (abs(step1) <= tol_s) and g1 != 0 and hi[b] - lo[b] >= tol_s
                x1 = x2
                if more and abs(x2 - x0) > span_s:
                    far = True
                    break
                if not more:
                    break
            # The look angles of the last point evaluated (the one in tau[b]).
            s, dx, dy, dz, c, sn = look
            el[b] = math.asin(min(max(s, -1.0), 1.0)) * deg
            de = (dx * (c * east[m, 0] - sn * east[m, 1])
                  + dy * (sn * east[m, 0] + c * east[m, 1]))
            dn = (dx * (c * north[m, 0] - sn * north[m, 1])
                  + dy * (sn * north[m, 0] + c * north[m, 1]) + dz * north[m, 2])
            az[b] = (math.atan2(de, dn) * deg) % 360.0
        x1_out[j] = x1
        far_out[j] = far


def _bracket_step(x, step, g, lo, hi, lo_neg, b
                  ):  # pragma: no cover - compiled by numba (bracketed for one point)
    """:func:`bracketed` for bracket ``b`` (``lo``, ``hi`` narrowed in place)."""
    if (g < 0) == lo_neg[b]:
        lo[b] = x
    else:
        hi[b] = x
    x_new = x - step
    if not math.isfinite(x_new) or x_new <= lo[b] or x_new >= hi[b]:
        x_new = 0.5 * (lo[b] + hi[b])
    return x_new


# --- look angles of the fine samples ---------------------------------------------------------

def el_rate(frames: geo.StationFrames, r_ecef, v_ecef, sel, st):
    """Elevation (deg) and its rate (deg/s) of the samples ``sel`` of ECEF positions and
    velocities (component tuples, as :func:`geometry.teme_to_ecef` gives them) seen from
    stations ``st`` (one per sample): :func:`geometry.look_angles` without azimuths."""
    if backend() == "numba":
        el, rate = np.empty(len(sel)), np.empty(len(sel))
        _jit("_el_rate_loop")(*r_ecef, *v_ecef, sel, st, frames.ecef_km, frames.up, el, rate)
        return el, rate
    el, _, rate = geo.look_angles(tuple(c[sel] for c in r_ecef), tuple(c[sel] for c in v_ecef),
                                  frames, st, False)
    return el, rate


def _el_rate_loop(x, y, z, vx, vy, vz, sel, st, ecef, up, el, rate
                  ):  # pragma: no cover - compiled by numba (el_rate's twin)
    for j in range(len(sel)):
        el[j], rate[j] = _el_rate_at(x, y, z, vx, vy, vz, sel[j], ecef, up, st[j])


def _el_rate_at(x, y, z, vx, vy, vz, i, ecef, up, m
                ):  # pragma: no cover - compiled by numba (a helper of the loops)
    """Elevation and its rate (deg, deg/s) of sample ``i`` from station ``m``."""
    deg = 180.0 / math.pi
    dx, dy, dz = x[i] - ecef[m, 0], y[i] - ecef[m, 1], z[i] - ecef[m, 2]
    u0, u1, u2 = up[m, 0], up[m, 1], up[m, 2]
    ru = dx * u0 + dy * u1 + dz * u2
    dist2 = dx * dx + dy * dy + dz * dz
    inv = 1.0 / math.sqrt(dist2)
    sin_el = min(max(ru * inv, -1.0), 1.0)
    vu = vx[i] * u0 + vy[i] * u1 + vz[i] * u2
    rv = dx * vx[i] + dy * vy[i] + dz * vz[i]
    d_sin = (vu - ru * rv / dist2) * inv
    return (math.asin(sin_el) * deg,
            d_sin / math.sqrt(max(1.0 - sin_el * sin_el, 1e-12)) * deg)


def sample_flags(el, rate, thr, sel, ok, s_loc, j, st) -> tuple:
    """Bracketing flags of samples ``sel`` of the shared fine samples (valid where ``ok``,
    of chunk satellite ``s_loc`` at grid index ``j``) seen from stations ``st`` (one per
    sample; each station's samples consecutive, in time order), with elevation ``el``, its
    rate and the horizon ``thr`` (deg): (elevation above the horizon f, rate (0 where
    invalid), ``s_loc`` and ``j`` of each sample, contig (sample and the next are
    consecutive valid samples of one satellite and station), up (f >= 0), cut_start and
    cut_end (up without a contiguous sample before / after)). All stations' samples in one
    pass."""
    if backend() == "numba":
        m = len(sel)
        f, rate_out = np.empty(m), np.empty(m)
        ss, jj = np.empty(m, s_loc.dtype), np.empty(m, j.dtype)
        contig = np.empty(max(m - 1, 0), np.bool_)
        up, cut_start, cut_end = (np.empty(m, np.bool_) for _ in range(3))
        _jit("_sample_flags_loop")(el, rate, thr, sel, ok, s_loc, j, st, f, rate_out, ss, jj,
                                   contig, up, cut_start, cut_end)
        return f, rate_out, ss, jj, contig, up, cut_start, cut_end
    good = ok[sel]
    f = np.where(good, el - thr, -1e3)
    rate = np.where(good, rate, 0.0)
    ss, jj = s_loc[sel], j[sel]
    contig = ((ss[1:] == ss[:-1]) & (jj[1:] == jj[:-1] + 1) & good[1:] & good[:-1]
              & (st[1:] == st[:-1]))
    up = f >= 0
    prev_c = np.concatenate([[False], contig])
    next_c = np.concatenate([contig, [False]])
    return f, rate, ss, jj, contig, up, up & ~prev_c, up & ~next_c


def _sample_flags_loop(el, rate_in, thr, sel, ok, s_loc, j, st, f, rate, ss, jj, contig, up,
                       cut_start, cut_end):  # pragma: no cover - compiled (its twin)
    m = len(sel)
    for i in range(m):
        k = sel[i]
        if ok[k]:
            f[i] = el[i] - thr[i]
            rate[i] = rate_in[i]
        else:
            f[i] = -1e3
            rate[i] = 0.0
        ss[i], jj[i] = s_loc[k], j[k]
        up[i] = f[i] >= 0
    for i in range(m - 1):
        contig[i] = (ss[i + 1] == ss[i] and jj[i + 1] == jj[i] + 1 and ok[sel[i + 1]]
                     and ok[sel[i]] and st[i + 1] == st[i])
    for i in range(m):
        before = i > 0 and contig[i - 1]
        after = i < m - 1 and contig[i]
        cut_start[i] = up[i] and not before
        cut_end[i] = up[i] and not after


def station_brackets(frames: geo.StationFrames, r_ecef, v_ecef, sel, st, thr, ok, s_loc,
                     j) -> tuple:
    """The samples stations' brackets need, of the shared fine samples ``sel`` seen from
    stations ``st`` (as :func:`el_rate` and :func:`sample_flags` take them; ``thr`` the
    horizon per sample, deg): (``keep``, positions in ``sel`` of the samples kept, in
    order; their elevation, rate and elevation above the horizon f; then, as positions in
    ``keep``: AOS and LOS brackets (a sign change of f between a sample and the next
    contiguous one), maxima (rate + -> -) and the window-edge cuts at a pass's first and
    last sample (up without a contiguous sample before / after)). A bracket's second
    sample is the next one in ``keep``; every sample kept is valid. The compiled loop is
    :func:`el_rate` and :func:`sample_flags` in one pass, and the brackets in a second."""
    if backend() == "numba":
        m = len(sel)
        keep = np.empty(m, np.int64)
        brackets = np.empty((5, m), np.int64)
        counts = np.zeros(6, np.int64)
        el, rate, f = np.empty(m), np.empty(m), np.empty(m)
        _jit("_station_brackets_loop")(*r_ecef, *v_ecef, sel, st, frames.ecef_km, frames.up,
                                       thr, ok, s_loc, j, keep, el, rate, f, brackets, counts)
        n = counts[5]
        return (keep[:n], el[:n], rate[:n], f[:n],
                *(brackets[k, :counts[k]] for k in range(5)))
    el, rate = el_rate(frames, r_ecef, v_ecef, sel, st)
    f, rate, _ss, _jj, contig, up, cut_start, cut_end = sample_flags(el, rate, thr, sel, ok,
                                                                    s_loc, j, st)
    i0 = np.flatnonzero(contig)
    i1 = i0 + 1
    found = [i0[~up[i0] & up[i1]], i0[up[i0] & ~up[i1]], i0[(rate[i0] > 0) & (rate[i1] <= 0)],
             np.flatnonzero(cut_start), np.flatnonzero(cut_end)]
    needed = np.zeros(len(sel) + 1, bool)
    for k, idx in enumerate(found):
        needed[idx] = True
        if k < 3:
            needed[idx + 1] = True
    keep = np.flatnonzero(needed[:-1])
    pos = np.cumsum(needed) - 1
    return (keep, el[keep], rate[keep], f[keep], *(pos[idx] for idx in found))


def _look_and_f(x, y, z, vx, vy, vz, sel, st, ecef, up, thr, ok, el, rate, f
                ):  # pragma: no cover - compiled by numba (pass 1 of _station_brackets_loop)
    """Look angles (as _el_rate_loop) and f (as _sample_flags_loop) of every sample; an
    invalid one gets f = -1e3 and rate 0."""
    for i in range(len(sel)):
        k = sel[i]
        if not ok[k]:
            f[i], rate[i] = -1e3, 0.0
            continue
        el[i], rate[i] = _el_rate_at(x, y, z, vx, vy, vz, k, ecef, up, st[i])
        f[i] = el[i] - thr[i]


def _station_brackets_loop(x, y, z, vx, vy, vz, sel, st, ecef, up, thr, ok, s_loc, j, keep,
                           el, rate, f, brackets, counts
                           ):  # pragma: no cover - compiled by numba (its twin)
    m = len(sel)
    _look_and_f(x, y, z, vx, vy, vz, sel, st, ecef, up, thr, ok, el, rate, f)
    # Pass 2: brackets between contiguous samples, cuts, and the samples they need.
    n_keep = 0
    at = -1  # the position in keep of sample i (-1: not kept yet)
    contig_before = False
    for i in range(m):
        contig = False
        if i + 1 < m:
            k, k1 = sel[i], sel[i + 1]
            contig = (s_loc[k1] == s_loc[k] and j[k1] == j[k] + 1 and ok[k1] and ok[k]
                      and st[i + 1] == st[i])
        is_up = f[i] >= 0
        hits = (False, False, False)
        if contig:
            up1 = f[i + 1] >= 0
            hits = (not is_up and up1, is_up and not up1, rate[i] > 0 and rate[i + 1] <= 0)
        cuts = (is_up and not contig_before, is_up and not contig)
        if at < 0 and (hits[0] or hits[1] or hits[2] or cuts[0] or cuts[1]):
            at = n_keep
            keep[n_keep] = i
            n_keep += 1
        for kind in range(3):
            if hits[kind]:
                brackets[kind, counts[kind]] = at
                counts[kind] += 1
        for kind in range(2):
            if cuts[kind]:
                brackets[3 + kind, counts[3 + kind]] = at
                counts[3 + kind] += 1
        at = -1
        if hits[0] or hits[1] or hits[2]:  # the bracket's second sample
            at = n_keep
            keep[n_keep] = i + 1
            n_keep += 1
        contig_before = contig
    # The samples kept, gathered in place (keep is increasing: c <= keep[c]).
    for c in range(n_keep):
        i = keep[c]
        el[c], rate[c], f[c] = el[i], rate[i], f[i]
    counts[5] = n_keep


# --- the near-miss test of maxima ------------------------------------------------------------

def peak_bound_deg(theta0: float, theta_rate: float, frames: geo.StationFrames, idx, st, tau, r,
                   r_apo, h: float, margin_rad: float) -> np.ndarray:
    """Upper bound of the (geocentric) elevation between samples ``idx`` and ``idx + 1``
    (TEME positions ``r`` at times ``tau``, ``h`` seconds apart, of satellites with apogee
    radius ``r_apo``, seen from stations ``st``; GMST theta0 + theta_rate * tau).

    The satellite stays on the great-circle arc between its two directions (as in the
    screening), so its geocentric angle from the station is at least the arc's distance from
    the station (less the station's own motion in half a step and ``margin_rad``); elevation
    grows with that angle shrinking and with the radius (bounded by the larger end + 50 km,
    or apogee).
    """
    if backend() == "numba":
        out = np.empty(len(idx))
        _jit("_peak_bound_loop")(theta0, theta_rate, frames.unit, frames.cos_lat,
                                 frames.radius_km, idx, st, tau, r, r_apo, h, margin_rad, out)
        return out
    st, tau0, r0, r1, r_apo = st[idx], tau[idx], r[idx], r[idx + 1], r_apo[idx]
    n0 = np.linalg.norm(r0, axis=-1)
    n1 = np.linalg.norm(r1, axis=-1)
    a, b = r0 / n0[:, None], r1 / n1[:, None]
    hv = np.cross(a, b)
    sin_ab = np.linalg.norm(hv, axis=-1)
    h_hat = hv / np.maximum(sin_ab, 1e-12)[:, None]
    q = np.cross(h_hat, a)
    theta = theta0 + theta_rate * (tau0 + 0.5 * h)
    c, s = np.cos(theta), np.sin(theta)
    u = geo.station_columns(frames.unit, st)
    p = np.stack([c * u[0] - s * u[1], s * u[0] + c * u[1], u[2] + 0.0 * c], -1)
    pa, pb = np.einsum("ij,ij->i", a, p), np.einsum("ij,ij->i", b, p)
    ph, pq = np.einsum("ij,ij->i", h_hat, p), np.einsum("ij,ij->i", q, p)
    alpha = np.arctan2(pq, pa)
    in_arc = (alpha >= 0) & (alpha <= np.arctan2(sin_ab, np.einsum("ij,ij->i", a, b)))
    psi = np.where(in_arc, np.arcsin(np.clip(np.abs(ph), 0, 1)),
                   np.arccos(np.clip(np.maximum(pa, pb), -1, 1)))
    psi = np.maximum(psi - EARTH_ROTATION_RAD_S * h / 2 * frames.cos_lat[st] - margin_rad, 0.0)
    r_hi = np.minimum(np.maximum(n0, n1) + 50.0, np.maximum(r_apo, np.maximum(n0, n1)))
    return np.degrees(np.arctan2(np.cos(psi) - frames.radius_km[st] / r_hi, np.sin(psi)))


def _peak_bound_loop(theta0, theta_rate, unit, cos_lat, radius_km, idx, st, tau, r, r_apo, h,
                     margin_rad, out):  # pragma: no cover - compiled by numba (its twin)
    deg = 180.0 / math.pi
    for j in range(len(idx)):
        i = idx[j]
        m = st[i]
        n0 = math.sqrt(r[i, 0] * r[i, 0] + r[i, 1] * r[i, 1] + r[i, 2] * r[i, 2])
        n1 = math.sqrt(r[i + 1, 0] * r[i + 1, 0] + r[i + 1, 1] * r[i + 1, 1]
                       + r[i + 1, 2] * r[i + 1, 2])
        a0, a1, a2 = r[i, 0] / n0, r[i, 1] / n0, r[i, 2] / n0
        b0, b1, b2 = r[i + 1, 0] / n1, r[i + 1, 1] / n1, r[i + 1, 2] / n1
        h0, h1, h2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        sin_ab = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        k = max(sin_ab, 1e-12)
        h0, h1, h2 = h0 / k, h1 / k, h2 / k
        q0, q1, q2 = h1 * a2 - h2 * a1, h2 * a0 - h0 * a2, h0 * a1 - h1 * a0
        theta = theta0 + theta_rate * (tau[i] + 0.5 * h)
        c, s = math.cos(theta), math.sin(theta)
        u0, u1, u2 = unit[m, 0], unit[m, 1], unit[m, 2]
        p0, p1, p2 = c * u0 - s * u1, s * u0 + c * u1, u2
        pa = a0 * p0 + a1 * p1 + a2 * p2
        pb = b0 * p0 + b1 * p1 + b2 * p2
        ph = h0 * p0 + h1 * p1 + h2 * p2
        pq = q0 * p0 + q1 * p1 + q2 * p2
        alpha = math.atan2(pq, pa)
        if alpha >= 0 and alpha <= math.atan2(sin_ab, a0 * b0 + a1 * b1 + a2 * b2):
            psi = math.asin(min(abs(ph), 1.0))
        else:
            psi = math.acos(min(max(max(pa, pb), -1.0), 1.0))
        psi = max(psi - EARTH_ROTATION_RAD_S * h / 2 * cos_lat[m] - margin_rad, 0.0)
        r_hi = min(max(n0, n1) + 50.0, max(r_apo[i], max(n0, n1)))
        out[j] = math.atan2(math.cos(psi) - radius_km[m] / r_hi, math.sin(psi)) * deg


# --- Sun flags of the events ------------------------------------------------------------------

def sun_flags(r_teme_km, tau_s, jd0: float, fr0: float, theta_rad, frames: geo.StationFrames,
              station, grid_s: float = 3600.0):
    """:func:`geometry.sun_flags` (sunlit, sine of the Sun's elevation at the station) for
    one station index per position; compiled, one pass over the events on the same
    interpolated Sun."""
    tau_s = np.asarray(tau_s, dtype=float)
    if backend() != "numba" or tau_s.size == 0:
        return geo.sun_flags(r_teme_km, tau_s, jd0, fr0, theta_rad, frames, station, grid_s)
    t0, t_grid, table = geo.sun_table(tau_s, jd0, fr0, grid_s)
    lit, sun_el = np.empty(len(tau_s), np.bool_), np.empty(len(tau_s))
    _jit("_sun_flags_loop")(r_teme_km, tau_s, t0, t_grid, table, grid_s, theta_rad, frames.up,
                            np.asarray(station, np.int64), EARTH_RADIUS_KM, lit, sun_el)
    return lit, sun_el


def _sun_flags_loop(r, tau, t0, t_grid, table, grid_s, theta, up, station, earth_km, lit,
                    sun_el):  # pragma: no cover - compiled by numba (geometry.sun_flags' twin)
    last = len(table) - 1
    e2 = earth_km * earth_km
    for j in range(len(tau)):
        i = min(max(np.int64(math.floor(tau[j] / grid_s)) - t0, 0), last)
        dt = tau[j] - t_grid[i]
        sx = table[i, 0] + table[i, 4] * dt
        sy = table[i, 1] + table[i, 5] * dt
        sz = table[i, 2] + table[i, 6] * dt
        dist = table[i, 3] + table[i, 7] * dt
        rx, ry, rz = r[j, 0], r[j, 1], r[j, 2]
        dx, dy, dz = sx * dist - rx, sy * dist - ry, sz * dist - rz
        rd = rx * dx + ry * dy + rz * dz
        r2 = rx * rx + ry * ry + rz * rz
        lit[j] = (rd >= 0 or r2 - rd * rd / (dx * dx + dy * dy + dz * dz) > e2) and r2 > e2
        c, s = math.cos(theta[j]), math.sin(theta[j])
        m = station[j]
        sun_el[j] = (c * sx + s * sy) * up[m, 0] + (c * sy - s * sx) * up[m, 1] + sz * up[m, 2]


# --- the result's order ----------------------------------------------------------------------

def permute_rows(rows: np.ndarray, order) -> None:
    """Rows of a structured array put in the ``order`` given (``rows[:] = rows[order]``) in
    place: the compiled loop follows the permutation's cycles, moving each row once (a bit
    per row of extra memory); numpy's moves each field in turn (one field's copy extra)."""
    if backend() == "numba" and rows.flags.c_contiguous and len(rows):
        raw = rows.view(np.uint8).reshape(len(rows), rows.dtype.itemsize)
        _jit("_permute_rows_loop")(raw, np.asarray(order, np.int64))
        return
    for name in rows.dtype.names:
        rows[name] = rows[name][order]


def _permute_rows_loop(raw, order):  # pragma: no cover - compiled by numba (its twin)
    n, w = raw.shape
    done = np.zeros(n, np.bool_)
    tmp = np.empty(w, np.uint8)
    for i in range(n):
        if done[i] or order[i] == i:
            continue
        tmp[:] = raw[i]
        j = i
        while True:
            done[j] = True
            k = order[j]
            if k == i:
                raw[j] = tmp
                break
            raw[j] = raw[k]
            j = k
