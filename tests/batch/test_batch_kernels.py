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

from tracker.batch import find_passes_batch, kernels
from tracker.station import HorizonMask, Station


@pytest.fixture(scope="module")
def amateur():
    sets = read_sets(TESTS.parent / "tle" / "data" / "amateur.txt")
    return [Satrec.twoline2rv(a, b) for _, a, b in sets], [n for n, _, _ in sets]


def with_impl(name: str, fn):
    """``fn()`` with the kernels' implementation ``name``."""
    previous = kernels.use(name)
    try:
        return fn()
    finally:
        kernels.use(previous)


@pytest.fixture
def numba_kernels():
    pytest.importorskip("numba")


def test_an_unknown_implementation_is_refused():
    with pytest.raises(ValueError, match="unknown kernel implementation 'fortran'"):
        kernels.use("fortran")


def test_the_environment_can_switch_the_compiled_kernels_off():
    code = "from tracker.batch import kernels; print(kernels.backend())"
    env = dict(os.environ, PYTHONPATH=str(REPO), TRACKER_NUMBA="0")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    assert out.stdout.strip() == "numpy"


def test_importing_the_batch_finder_does_not_load_numba():
    code = "import sys, tracker.batch, tracker.api; print('numba' in sys.modules)"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    assert out.stdout.strip() == "False"


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
