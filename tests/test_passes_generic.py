"""The generic pass finder (non-satellite targets): fixed stars through skyfield's Star, and a
synthetic target with two culminations in one pass, against fine brute-force sampling."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.clock import utc
from tracker.passes import find_passes
from tracker.skytrack import SkyTrack
from tracker.station import Station
from tracker.timescale import time_from_posix

START = utc(2026, 8, 23, 0, 0)
END = utc(2026, 8, 25, 0, 0)
DELFT = Station("delft", 52.0, 4.4, 10.0)


class StarTarget:
    """A fixed RA/Dec source (what the celestial helper's radio sources look like)."""

    kind = "star"

    def __init__(self, name: str, ra_hours: float, dec_deg: float):
        from skyfield.api import Star

        self.name = name
        self.star = Star(ra_hours=ra_hours, dec_degrees=dec_deg)

    def observe(self, station: Station, t_s) -> SkyTrack:
        from tracker.ephemeris import load_ephemeris

        eph = load_ephemeris()
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        observer = eph["earth"] + station.topos()
        alt, az, _ = observer.at(time_from_posix(t_s)).observe(self.star).apparent().altaz()
        return SkyTrack.from_azel(t_s, az.degrees, alt.degrees, name=self.name)


class TwoHumps:
    """Up for 1200 s every 3 h, with two culminations per pass; the second one is higher."""

    kind = "schedule"
    name = "two-humps"
    period_s = 3 * 3600.0
    length_s = 1200.0

    def el(self, t_s):
        u = np.mod(np.asarray(t_s, dtype=float) - START.timestamp(), self.period_s) / self.length_s
        up = 30 * np.sin(np.pi * u) + 8 * np.sin(3 * np.pi * u) + 4 * u * np.sin(np.pi * u)
        return np.where(u <= 1.0, up, -10.0)

    def observe(self, station: Station, t_s) -> SkyTrack:
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        return SkyTrack.from_azel(t_s, np.full(t_s.shape, 90.0), self.el(t_s), name=self.name)


@pytest.fixture(scope="module")
def ephemeris():
    pytest.importorskip("skyfield_data")


def brute(target: StarTarget, station: Station, t0: float, t1: float, step_s: float):
    t = np.arange(t0, t1, step_s)
    el = target.observe(station, t).el_deg - station.min_el_deg
    return t, el


def test_star_rise_set_culmination(ephemeris):
    sirius = StarTarget("Sirius", 6.7525, -16.7161)
    passes = find_passes(sirius, DELFT, START, END)
    assert len(passes) == 2  # a sidereal day is shorter than a day: two passes in 48 h
    for p in passes:
        assert p.kind == "star" and not p.sunlit and not p.visible
        for when, rising in ((p.aos, True), (p.los, False)):
            t, el = brute(sirius, DELFT, when.timestamp() - 5, when.timestamp() + 5, 0.1)
            i = np.flatnonzero((el[1:] > 0) != (el[:-1] > 0))
            assert len(i) == 1 and (el[i[0] + 1] > 0) == rising
            t_ref = t[i[0]] + 0.1 * el[i[0]] / (el[i[0]] - el[i[0] + 1])
            assert abs(t_ref - when.timestamp()) < 1.0
        # Max elevation of a star: 90 - lat + dec, at transit, due south
        assert p.max_el_deg == pytest.approx(90 - 52.0 - 16.7161, abs=0.05)
        assert p.tca_az_deg == pytest.approx(180.0, abs=0.1)
        # the transit is in the middle of the pass (symmetric apart from refraction-free geometry)
        mid = p.aos.timestamp() + p.duration_s / 2
        assert abs(p.tca.timestamp() - mid) < 30
        # semi-diurnal arc: cos H0 = -tan(lat) tan(dec), in sidereal time
        h0_deg = np.degrees(np.arccos(-np.tan(np.radians(52.0)) * np.tan(np.radians(-16.7161))))
        assert p.duration_s == pytest.approx(2 * h0_deg / 15.0 * 3600 * 0.99727, abs=120)


def test_circumpolar_and_never_rising_stars(ephemeris):
    vega = StarTarget("Vega", 18.6156, 38.7837)   # dec > 90 - 52: never sets at 52 N
    passes = find_passes(vega, DELFT, START, END)
    assert len(passes) == 1 and passes[0].always_up
    assert passes[0].duration_s == pytest.approx(2 * 86400)
    canopus = StarTarget("Canopus", 6.3992, -52.6957)  # never rises at 52 N
    assert find_passes(canopus, DELFT, START, END) == []


def test_min_el_applies_to_stars(ephemeris):
    sirius = StarTarget("Sirius", 6.7525, -16.7161)
    low = find_passes(sirius, DELFT, START, END)
    high = find_passes(sirius, DELFT, START, END, min_el_deg=15.0)
    assert len(high) == 2
    assert all(h.duration_s < lo.duration_s for h, lo in zip(high, low, strict=True))
    _, _, el = (0, 0, sirius.observe(DELFT, [high[0].aos.timestamp()]).el_deg)
    assert el[0] == pytest.approx(15.0, abs=0.01)


def test_two_culminations_pick_the_highest():
    target = TwoHumps()
    passes = find_passes(target, DELFT, START, utc(2026, 8, 23, 9))
    assert len(passes) == 3
    for p in passes:
        t = np.arange(p.aos.timestamp(), p.los.timestamp(), 0.01)
        el = target.el(t)
        assert p.max_el_deg == pytest.approx(el.max(), abs=1e-4)
        assert abs(p.tca.timestamp() - t[np.argmax(el)]) < 0.05
        u = (p.tca.timestamp() - START.timestamp()) % target.period_s / target.length_s
        assert u > 0.5  # the second, higher hump
        assert p.duration_s == pytest.approx(target.length_s, abs=0.05)


def test_pass_in_progress_at_start_generic():
    target = TwoHumps()
    start = utc(2026, 8, 23, 3, 5)  # 5 minutes into the second pass
    passes = find_passes(target, DELFT, start, utc(2026, 8, 23, 4))
    assert len(passes) == 1
    p = passes[0]
    assert p.in_progress_at_start and p.aos_known
    assert abs(p.aos.timestamp() - utc(2026, 8, 23, 3).timestamp()) < 0.05
    track = p.track(step_s=5.0)
    assert len(track) == int(np.ceil(p.duration_s / 5.0)) + 1
    assert np.all(track.el_deg >= -0.01)
