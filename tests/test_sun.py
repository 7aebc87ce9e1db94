"""The low-precision Sun (tracker.sun) against DE421: a satellite's sunlit and visible flags
from find_passes are the ones skyfield's ephemeris gives on the same samples."""

from __future__ import annotations

import numpy as np
import pytest

from tle.catalog import Catalog
from tracker.clock import utc
from tracker.passes import VISIBLE_SUN_EL_DEG, _sunlit_visible, find_passes
from tracker.station import Station
from tracker.sun import in_sunlight, sun_teme_unit
from tracker.targets import SatelliteTarget
from tracker.timescale import time_from_posix

START = utc(2026, 8, 21)
STATIONS = (Station("delft", 52.0, 4.4), Station("cape town", -33.9, 18.4),
            Station("fairbanks", 64.8, -147.7))
SAMPLES = 40  # per pass, as find_passes samples


def de421_flags(target: SatelliteTarget, station: Station, aos, los):
    """Per-sample (sunlit, dark) from DE421: skyfield's is_sunlit and the apparent Sun."""
    from tracker.ephemeris import load_ephemeris

    eph = load_ephemeris()
    frac = np.linspace(0.0, 1.0, SAMPLES)
    t_s = (aos[:, None] + (los - aos)[:, None] * frac[None, :]).ravel()
    t = time_from_posix(t_s)
    lit = np.asarray(target.satellite.at(t).is_sunlit(eph), dtype=bool)
    alt, _, _ = (eph["earth"] + station.topos()).at(t).observe(eph["sun"]).apparent().altaz()
    shape = (len(aos), SAMPLES)
    return lit.reshape(shape), (alt.degrees < VISIBLE_SUN_EL_DEG).reshape(shape)


@pytest.fixture(scope="module")
def targets() -> list[SatelliteTarget]:
    # Every 9th set of the bundled snapshot: LEO, MEO, Molniya and GEO orbits alike.
    sets = sorted(Catalog.bundled_snapshot(), key=lambda es: es.norad_id)[::9]
    return [SatelliteTarget(es) for es in sets]


def test_flags_equal_de421_on_every_pass(targets):
    n_passes = n_lit = n_visible = 0
    for target in targets:
        for station in STATIONS:
            passes = find_passes(target, station, START, START.timestamp() + 86400.0)
            if not passes:
                continue
            aos = np.array([p.aos.timestamp() for p in passes])
            los = np.array([p.los.timestamp() for p in passes])
            lit, dark = de421_flags(target, station, aos, los)
            assert [p.sunlit for p in passes] == lit.any(axis=1).tolist(), target.name
            assert [p.visible for p in passes] == (lit & dark).any(axis=1).tolist(), target.name
            n_passes += len(passes)
            n_lit += sum(p.sunlit for p in passes)
            n_visible += sum(p.visible for p in passes)
    # the comparison is not vacuous: many passes, lit and in shadow, visible and not
    assert n_passes > 500 and 0 < n_visible < n_lit < n_passes


def test_sun_direction_within_a_hundredth_of_a_degree_of_de421():
    from tracker.ephemeris import load_ephemeris

    eph = load_ephemeris()
    t_s = START.timestamp() + np.linspace(-3e8, 3e8, 50)   # 1997 .. 2035
    t = time_from_posix(t_s)
    # DE421's apparent Sun in the true equator and equinox of date (TEME to an arcsecond)
    ref = (eph["earth"]).at(t).observe(eph["sun"]).apparent().frame_xyz(
        _true_equator_of_date()).au
    ref = ref / np.linalg.norm(ref, axis=0)
    ours = sun_teme_unit(t_s / 86400.0 + 2440587.5)
    sep_deg = np.degrees(np.arccos(np.clip(np.sum(ours * ref.T, axis=1), -1, 1)))
    assert sep_deg.max() < 0.01


def _true_equator_of_date():
    from skyfield.framelib import true_equator_and_equinox_of_date

    return true_equator_and_equinox_of_date


def test_shadow_geometry():
    sun = (1.5e8, 0.0, 0.0)
    r = np.array([[7000.0, 0, 0], [-7000.0, 0, 0], [-7000.0, 6500.0, 0], [6000.0, 0, 0]])
    lit = in_sunlight((r[:, 0], r[:, 1], r[:, 2]), sun)
    # day side; behind the Earth; behind but above the shadow cylinder; inside the Earth
    assert lit.tolist() == [True, False, True, False]


def test_only_satellites_have_flags():
    from tracker.celestial import resolve

    sun = resolve("Sun")
    lit, visible = _sunlit_visible(sun, STATIONS[0], np.array([0.0]), np.array([60.0]))
    assert not lit.any() and not visible.any()
