"""The batch finder's kernels: the compiled (numba) loops give what the numpy reference gives,
kernel by kernel and for the whole finder; numba is loaded only when a kernel runs."""

from __future__ import annotations

import os
import subprocess
import sys
from datetime import timedelta

import numpy as np
import pytest
from _paths import REPO, TESTS
from sgp4.api import Satrec
from test_batch_finder import DELFT, QUITO, START, read_sets

from tracker import compiled
from tracker.batch import find_passes_batch, kernels
from tracker.station import HorizonMask, Station


@pytest.fixture(scope="module")
def amateur():
    sets = read_sets(TESTS.parent / "tle" / "data" / "amateur.txt")
    return [Satrec.twoline2rv(a, b) for _, a, b in sets], [n for n, _, _ in sets]


def with_impl(name: str, fn):
    """``fn()`` with the kernels' implementation ``name``."""
    previous = compiled.use(name)
    try:
        return fn()
    finally:
        compiled.use(previous)


@pytest.fixture
def numba_kernels():
    pytest.importorskip("numba")


def test_an_unknown_implementation_is_refused():
    with pytest.raises(ValueError, match="unknown kernel implementation 'fortran'"):
        compiled.use("fortran")


def backend_after(work: float, **env) -> list[str]:
    """The automatic choice after a job of ``work`` satellite-station-days was announced,
    in a fresh interpreter: [backend, whether numba is loaded after a kernel ran]."""
    code = ("import sys, numpy as np; from tracker.batch import kernels; "
            f"kernels.announce_work({work}); print(kernels.backend()); "
            "kernels.hermite_root(np.zeros(3), np.ones(3), np.ones(3), np.ones(3), 1.0); "
            "print('numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(REPO), **env), check=True)
    return out.stdout.split()


def test_small_jobs_do_not_pay_for_loading_numba():
    assert backend_after(kernels.COMPILED_MIN_WORK / 2) == ["numpy", "False"]


def test_a_big_job_uses_the_compiled_kernels_unless_switched_off(numba_kernels):
    assert backend_after(kernels.COMPILED_MIN_WORK) == ["numba", "True"]
    assert backend_after(1e9, TRACKER_NUMBA="0") == ["numpy", "False"]


def test_a_numba_that_cannot_be_imported_leaves_the_numpy_kernels(tmp_path):
    # installed, but refusing to load, as a numba built for an older numpy does
    (tmp_path / "numba").mkdir()
    (tmp_path / "numba" / "__init__.py").write_text(
        'raise ImportError("Numba needs NumPy 2.3 or less")\n')
    code = ("import numpy as np; from tracker.batch import kernels; "
            "kernels.announce_work(1e9); print(kernels.backend()); "
            "print(kernels.hermite_root(np.zeros(3), np.ones(3), np.ones(3), np.ones(3), 1.0)"
            ".shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{REPO}"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["numpy", "(3,)"]


def test_importing_the_batch_finder_does_not_load_numba():
    code = "import sys, tracker.batch, tracker.api; print('numba' in sys.modules)"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    assert out.stdout.strip() == "False"


def test_threads_that_start_together_compile_each_kernel_once(amateur, numba_kernels,
                                                           monkeypatch):
    """Dask's threaded workers call the kernels for the first time at the same moment."""
    from concurrent.futures import ThreadPoolExecutor

    satrecs, names = amateur
    monkeypatch.setattr(kernels._jit, "compiled", {})  # as in a fresh process (disk cache kept)
    previous = compiled.use("numba")
    try:
        with ThreadPoolExecutor(4) as pool:
            runs = list(pool.map(lambda i: find_passes_batch(
                satrecs[i::4], names[i::4], [DELFT], START, START + timedelta(hours=12)),
                range(4)))
    finally:
        compiled.use(previous)
    assert all(len(t) > 20 for t in runs)
    assert {"_solve_cubic_loop", "_correct_loop", "_fine_screen_loop"} <= set(kernels._jit.compiled)


MASKED = Station("Masked", 52.0, 4.37, 10.0, 1.0,
                 HorizonMask((0.0, 90.0, 180.0, 270.0), (20.0, 2.0, 2.0, 2.0)))


@pytest.mark.parametrize("stations", [(DELFT,), (DELFT, QUITO), (QUITO, MASKED)],
                         ids=["one", "two", "masked"])
def test_the_finder_gives_the_same_passes_with_either_implementation(amateur, numba_kernels,
                                                                    stations):
    satrecs, names = amateur

    def run():
        return find_passes_batch(satrecs, names, list(stations), START,
                                 START + timedelta(days=2))

    ref, fast = with_impl("numpy", run), with_impl("numba", run)
    a, b = ref.passes, fast.passes
    assert len(a) > 500 * len(stations) and len(a) == len(b)
    for key in ("sat", "station", "aos_clipped", "los_clipped", "sunlit", "visible"):
        assert np.array_equal(a[key], b[key]), key
    for key in ("aos_s", "tca_s", "los_s"):
        assert np.max(np.abs(a[key] - b[key])) <= 1e-6, key
    for key in ("max_el_deg", "aos_az_deg", "tca_az_deg", "los_az_deg"):
        assert np.max(np.abs(a[key] - b[key])) <= 1e-9, key
    assert ref.stats == fast.stats


def random_arcs(rng, S: int, K: int, n: int):
    """Coarse intervals of S satellites with random orbit planes and arcs, and a station
    track."""
    A = rng.normal(size=(S, K, 3))
    A /= np.linalg.norm(A, axis=-1)[..., None]
    q = np.cross(rng.normal(size=(S, K, 3)), A)
    q /= np.linalg.norm(q, axis=-1)[..., None]
    track = kernels.StationTrack(np.cumsum(rng.uniform(0.0, 0.1, K * n)), 0.8, 0.6)
    return (A, q, rng.uniform(0.0, 5.0, (S, K)), rng.uniform(0.0, 0.9, S), track,
            rng.uniform(0.5, 1.0, S), rng.random(S) < 0.98)


def test_fine_screen_decides_like_the_numpy_screen(numba_kernels):
    """float32 (numpy) and float64 (compiled) decide alike except within float32 rounding of
    the cone's edge, where the compiled one is the exact one."""
    rng = np.random.default_rng(3)
    S, K, n = 300, 40, 8
    A, q, phi, ecc, track, cos_lim, screenable = random_arcs(rng, S, K, n)
    ss, kk = np.nonzero(rng.random((S, K)) < 0.3)

    def run():
        return kernels.fine_screen(A, q, phi, ss, kk, ecc, n, 3600.0, track, cos_lim,
                                   screenable)

    ref, fast = with_impl("numpy", run), with_impl("numba", run)
    assert ref.shape == fast.shape == (len(ss), n)
    assert 0.05 < ref.mean() < 0.95
    assert np.all(fast[~screenable[ss]])
    assert np.mean(ref != fast) < 1e-3


@pytest.mark.parametrize("impl", ["numpy", "numba"])
def test_fine_screen_decides_alike_with_the_stations_shared_sub_arcs(impl, request):
    """The sub-arcs computed once for many stations (shared_arcs) give each station the
    decisions of its own screen, bit for bit, with either implementation."""
    if impl == "numba":
        request.getfixturevalue("numba_kernels")
    rng = np.random.default_rng(4)
    S, K, n = 200, 30, 8
    A, q, phi, ecc, track, cos_lim, screenable = random_arcs(rng, S, K, n)
    any_ss, any_kk = np.nonzero(rng.random((S, K)) < 0.5)
    rows = np.full((S, K), -1, np.int64)
    rows[any_ss, any_kk] = np.arange(len(any_ss))
    pick = rng.random(len(any_ss)) < 0.6  # one station's candidates among all stations'
    ss, kk = any_ss[pick], any_kk[pick]

    def run():
        arcs = kernels.shared_arcs(phi, any_ss, any_kk, ecc, n, 3600.0)
        assert arcs.kind == impl
        return (kernels.fine_screen(A, q, phi, ss, kk, ecc, n, 3600.0, track, cos_lim,
                                    screenable, arcs, rows[ss, kk]),
                kernels.fine_screen(A, q, phi, ss, kk, ecc, n, 3600.0, track, cos_lim,
                                    screenable))

    shared, own = with_impl(impl, run)
    assert 0.05 < own.mean() < 0.95
    assert np.array_equal(shared, own)


@pytest.mark.parametrize("slope", [False, True])
def test_hermite_root_is_the_same(numba_kernels, slope):
    rng = np.random.default_rng(5)
    m = 5000
    f0, f1 = rng.normal(size=m), rng.normal(size=m)
    d0, d1 = rng.normal(size=m), rng.normal(size=m)
    width = 480.0 if slope else rng.uniform(10.0, 500.0, m)

    def run():
        return kernels.hermite_root(f0, d0, f1, d1, width, slope)

    ref, fast = with_impl("numpy", run), with_impl("numba", run)
    assert np.array_equal(ref, fast)
    assert np.all((ref >= 0) & (ref <= 1))


def sky_of(stations) -> tuple[kernels.Sky, object]:
    from tracker.batch import geometry as geo

    frames = geo.StationFrames.from_stations(list(stations))
    sin_min = np.sin(np.radians(frames.min_el_deg))
    return kernels.Sky(1.3, 7.292115e-5, frames.ecef_km, frames.up, frames.east, frames.north,
                       sin_min), frames


def leo_states(rng, m: int):
    """Circular-ish low orbits: TEME positions and velocities (m, 3) and the two-body
    acceleration."""
    r = rng.normal(size=(m, 3))
    r *= (6378.0 + rng.uniform(300.0, 1500.0, m) / np.linalg.norm(r, axis=1))[:, None]
    v = np.cross(r, rng.normal(size=(m, 3)))
    v *= (7.5 / np.linalg.norm(v, axis=1))[:, None]
    n2 = np.sum(r * r, axis=1)
    return r, v, r * (-398600.4418 / (n2 * np.sqrt(n2)))[:, None]


@pytest.mark.parametrize("tca", [False, True])
def test_solve_cubic_and_correct_take_the_same_steps(numba_kernels, tca):
    """Root solving on the cubic and the correction from an exact state: same roots, same
    brackets, same look angles (to rounding) with either implementation."""
    rng = np.random.default_rng(11)
    m, h = 4000, 480.0
    sky, _frames = sky_of((DELFT, QUITO))
    r0, v0, _ = leo_states(rng, m)
    r1 = r0 + v0 * h
    cubic = kernels.Cubic.through(rng.uniform(0, 1e5, m), h, r0, v0, r1, v0)
    k = np.arange(m)
    st = rng.integers(0, 2, m)
    lo, hi = cubic.t0.copy(), cubic.t0 + h
    lo_neg = rng.random(m) < 0.5
    guess = lo + rng.random(m) * h

    def solve():
        return kernels.solve_cubic(sky, cubic, k, st, lo, hi, lo_neg, guess, 10.0, tca)

    ref, fast = with_impl("numpy", solve), with_impl("numba", solve)
    assert np.all((ref >= lo) & (ref <= hi))
    assert np.max(np.abs(ref - fast)) <= 1e-6

    r_s, v_s, a_s = leo_states(rng, m)

    def correct():
        lo2, hi2 = lo.copy(), hi.copy()
        out = (np.zeros(m), np.zeros(m), np.zeros(m), np.zeros((m, 3)))
        x1, far = kernels.correct(sky, k, guess, r_s, v_s, a_s, st, lo2, hi2, lo_neg, 0.02,
                                  1.0, tca, out)
        return x1, far, lo2, hi2, out

    (x_a, far_a, lo_a, hi_a, out_a), (x_b, far_b, lo_b, hi_b, out_b) = (
        with_impl("numpy", correct), with_impl("numba", correct))
    assert np.array_equal(far_a, far_b) and 0 < far_a.sum() < m
    for a, b in ((x_a, x_b), (lo_a, lo_b), (hi_a, hi_b), (out_a[0], out_b[0])):
        assert np.max(np.abs(a - b)) <= 1e-6
    assert np.max(np.abs(out_a[1] - out_b[1])) <= 1e-9          # elevation
    assert np.max(np.abs(out_a[2] - out_b[2])) <= 1e-9          # azimuth
    assert np.max(np.abs(out_a[3] - out_b[3])) <= 1e-6          # position, km


def test_sample_flags_are_the_same(numba_kernels):
    """The bracketing flags of stations' samples: runs of consecutive grid times per
    satellite, invalid samples, station and satellite changes, window edges."""
    rng = np.random.default_rng(17)
    shared = 4000
    s_loc = np.repeat(np.arange(40), shared // 40)
    j = np.tile(np.arange(shared // 40), 40) + rng.integers(0, 2, shared).cumsum() % 3
    ok = rng.random(shared) < 0.97
    per_station = [np.sort(rng.choice(shared, 1500, replace=False)) for _ in range(3)]
    sel = np.concatenate(per_station)
    st = np.repeat(np.arange(3), 1500)
    el = rng.normal(0.0, 10.0, len(sel))
    rate = rng.normal(0.0, 0.05, len(sel))
    thr = np.array([0.0, 5.0, 10.0])[st]

    def run():
        return kernels.sample_flags(el, rate, thr, sel, ok, s_loc, j, st)

    ref, fast = with_impl("numpy", run), with_impl("numba", run)
    for a, b in zip(ref, fast, strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    f, _rate, _ss, _jj, contig, up, cut_start, cut_end = ref
    assert 0.2 < contig.mean() < 0.9 and np.any(f == -1e3)
    assert 0 < cut_start.sum() < up.sum() and cut_end.sum() > 0


def test_look_angles_and_the_peak_bound_are_the_same(numba_kernels):
    rng = np.random.default_rng(13)
    m = 5000
    _sky, frames = sky_of((DELFT, QUITO))
    r, v, _ = leo_states(rng, m + 1)
    sel = np.sort(rng.integers(0, m, 3000))
    st = rng.integers(0, 2, m + 1)
    comps = tuple(r[:, i].copy() for i in range(3)), tuple(v[:, i].copy() for i in range(3))

    def look():
        return kernels.el_rate(frames, *comps, sel, st[sel])

    (el_a, rate_a), (el_b, rate_b) = with_impl("numpy", look), with_impl("numba", look)
    assert np.max(np.abs(el_a - el_b)) <= 1e-9 and np.max(np.abs(rate_a - rate_b)) <= 1e-12
    assert el_a.min() < 0 < el_a.max()

    # Steps of 60 s along the orbits: sample 2i at the start, 2i + 1 at the end.
    path = np.empty((2 * m, 3))
    path[0::2], path[1::2] = r[:m], r[:m] + v[:m] * 60.0
    starts = 2 * np.arange(m)
    st2 = np.repeat(st[:m], 2)
    tau = np.arange(2 * m) * 30.0
    r_apo = np.full(2 * m, 8000.0)

    def bound():
        return kernels.peak_bound_deg(1.3, 7.292115e-5, frames, starts, st2, tau, path, r_apo,
                                      60.0, 0.01)

    a, b = with_impl("numpy", bound), with_impl("numba", bound)
    assert np.max(np.abs(a - b)) <= 1e-9
    assert 0.1 < np.mean(a > 0) < 0.9


def test_station_brackets_are_the_same(numba_kernels):
    """The fused look angles, flags and brackets of stations' samples (compiled) against
    el_rate, sample_flags and the brackets taken from them (numpy): the same samples kept,
    the same brackets and cuts, look angles to rounding."""
    rng = np.random.default_rng(29)
    shared = 4000
    _sky, frames = sky_of((DELFT, QUITO, MASKED))
    r, v, _ = leo_states(rng, shared)
    comps = tuple(r[:, i].copy() for i in range(3)), tuple(v[:, i].copy() for i in range(3))
    s_loc = np.repeat(np.arange(40), shared // 40)
    j = np.tile(np.arange(shared // 40), 40) + rng.integers(0, 2, shared).cumsum() % 3
    ok = rng.random(shared) < 0.97
    sel = np.concatenate([np.sort(rng.choice(shared, 1500, replace=False)) for _ in range(3)])
    st = np.repeat(np.arange(3), 1500)
    thr = np.array([0.0, -20.0, 5.0])[st] + rng.uniform(0.0, 1.0, len(sel)) * (st == 2)

    def run():
        return kernels.station_brackets(frames, *comps, sel, st, thr, ok, s_loc, j)

    ref, fast = with_impl("numpy", run), with_impl("numba", run)
    keep, _el, rate, f = ref[:4]
    for k, (a, b) in enumerate(zip(ref, fast, strict=True)):
        if k in (1, 2, 3):
            assert np.max(np.abs(a - b)) <= 1e-9
        else:
            assert a.dtype == b.dtype and np.array_equal(a, b), k
    aos, los, mx, cs, ce = ref[4:]
    assert min(map(len, (aos, los, mx, cs, ce))) > 10 and len(keep) < len(sel)
    assert np.all(f[aos] < 0) and np.all(f[aos + 1] >= 0) and np.all(f[los + 1] < 0)
    assert np.all(rate[mx] > 0) and np.all(rate[mx + 1] <= 0) and np.all(f[cs] >= 0)
    assert np.all(ok[sel[keep]]) and np.all(np.diff(keep) > 0)


def test_sun_flags_and_the_row_order_are_the_same(numba_kernels):
    from tracker.batch import PASS_DTYPE
    from tracker.batch import geometry as geo

    rng = np.random.default_rng(31)
    _sky, frames = sky_of((DELFT, QUITO))
    r, _, _ = leo_states(rng, 3000)
    r[:10] *= (3000.0 / np.linalg.norm(r[:10], axis=1))[:, None]  # inside the Earth: not lit
    tau = rng.uniform(0.0, 7 * 86400.0, len(r))
    theta = 1.3 + 7.292115e-5 * tau
    st = rng.integers(0, 2, len(r))

    def flags():
        return kernels.sun_flags(r, tau, 2461118.5, 0.2, theta, frames, st)

    (lit_a, el_a), (lit_b, el_b) = with_impl("numpy", flags), with_impl("numba", flags)
    assert np.array_equal(lit_a, lit_b) and np.max(np.abs(el_a - el_b)) <= 1e-12
    assert np.array_equal(lit_a, geo.sun_flags(r, tau, 2461118.5, 0.2, theta, frames, st)[0])
    assert 0.3 < lit_a.mean() < 0.95 and not lit_a[:10].any()

    rows = np.zeros(5000, PASS_DTYPE)
    for name in PASS_DTYPE.names:
        rows[name] = rng.integers(0, 2 if PASS_DTYPE[name].kind == "b" else 10**6, len(rows))
    order = np.concatenate([np.arange(100), 100 + rng.permutation(len(rows) - 100)])
    for impl in ("numpy", "numba"):
        mine = rows.copy()
        with_impl(impl, lambda m=mine: kernels.permute_rows(m, order))
        assert mine.tobytes() == rows[order].tobytes(), impl


def test_the_cubic_between_samples_is_the_same(numba_kernels):
    rng = np.random.default_rng(37)
    r, v, _ = leo_states(rng, 2000)
    tau = np.arange(2000) * 480.0
    idx = np.sort(rng.choice(1999, 700, replace=False))
    ref = with_impl("numpy", lambda: kernels.Cubic.between(tau, 480.0, r, v, idx))
    fast = with_impl("numba", lambda: kernels.Cubic.between(tau, 480.0, r, v, idx))
    for name in ("t0", "r0", "c1", "c2", "c3", "x_ref", "dr", "dv"):
        assert np.array_equal(getattr(ref, name), getattr(fast, name)), name
    assert np.allclose(ref(np.arange(700), tau[idx] + 480.0)[0], r[idx + 1])
