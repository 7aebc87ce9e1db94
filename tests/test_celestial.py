"""Sun, Moon, planets and fixed sources against PyEphem (an independent implementation)."""

from __future__ import annotations

import itertools
import math
from datetime import datetime, timezone

import numpy as np
import pytest

from tracker.celestial import (
    RADIO_SOURCES,
    FixedTarget,
    SolarSystemTarget,
    event_labels,
    parse_radec,
    resolve,
)
from tracker.errors import ConfigError, TargetError
from tracker.passes import find_passes
from tracker.skytrack import angular_separation_deg
from tracker.station import HorizonMask, Station

ephem = pytest.importorskip("ephem")
pytest.importorskip("skyfield_data")

UTC = timezone.utc
T0 = datetime(2026, 8, 22, tzinfo=UTC)
T0_S = T0.timestamp()
STATIONS = [Station("Dwingeloo", 52.81, 6.40, 20.0), Station("Sydney", -33.87, 151.21, 50.0),
            Station("Longyearbyen", 78.22, 15.65, 10.0)]


def _observer(station: Station) -> ephem.Observer:
    o = ephem.Observer()
    o.lat = math.radians(station.lat_deg)
    o.lon = math.radians(station.lon_deg)
    o.elevation = station.alt_m
    o.pressure = 0.0  # refraction off, like tracker.celestial
    o.horizon = 0.0
    return o


def _edate(t_s: float) -> ephem.Date:
    return ephem.Date(datetime.fromtimestamp(t_s, UTC).replace(tzinfo=None))


def _posix(d) -> float:
    return ephem.Date(d).datetime().replace(tzinfo=UTC).timestamp()


def _ephem_body(target):
    if isinstance(target, FixedTarget):
        body = ephem.FixedBody()
        body._ra = math.radians(target.ra_hours * 15.0)
        body._dec = math.radians(target.dec_deg)
        body._epoch = ephem.J2000
        return body
    return getattr(ephem, target.name)()


def _ephem_azel(target, station, t_s):
    o = _observer(station)
    body = _ephem_body(target)
    az, el = [], []
    for t in t_s:
        o.date = _edate(t)
        body.compute(o)
        az.append(math.degrees(body.az))
        el.append(math.degrees(body.alt))
    return np.array(az), np.array(el)


@pytest.mark.parametrize("name", ["sun", "moon", "mars", "jupiter", "saturn", "cas a", "tau-a",
                                  "radec:12:30:49.4,+12:23:28"])
@pytest.mark.parametrize("station", STATIONS, ids=lambda s: s.name)
def test_azel_matches_pyephem_within_005_deg(name, station):
    target = resolve(name)
    t_s = T0_S + np.arange(0.0, 2 * 86400.0, 2 * 3600.0 + 17.0)
    track = target.observe(station, t_s)
    az, el = _ephem_azel(target, station, t_s)
    sep = angular_separation_deg(track.az_deg, track.el_deg, az, el)
    assert sep.max() < 0.05, (name, sep.max())
    # And not trivially: the target really moves through the sky over the window.
    assert np.ptp(track.el_deg) > 5.0


def test_dense_observe_is_interpolated_but_still_exact_to_1e3_deg():
    moon = resolve("moon")
    station = STATIONS[0]
    t_s = T0_S + np.arange(0.0, 12 * 3600.0, 1.0)
    dense = moon.observe(station, t_s)
    assert dense.meta.get("interpolated_node_s")
    pick = np.arange(0, t_s.size, 331)
    exact = moon.observe(station, t_s[pick])
    assert "interpolated_node_s" not in exact.meta
    sep = angular_separation_deg(dense.az_deg[pick], dense.el_deg[pick], exact.az_deg,
                                 exact.el_deg)
    assert sep.max() < 1e-3
    assert np.allclose(dense.range_km[pick], exact.range_km, atol=0.1)


def test_moon_range_and_range_rate_are_consistent():
    track = resolve("moon").observe(STATIONS[0], T0_S + np.arange(0.0, 86400.0, 60.0))
    assert np.all((track.range_km > 350_000) & (track.range_km < 414_000))
    finite_diff = np.gradient(track.range_km, track.t_s)
    assert np.allclose(track.range_rate_km_s[1:-1], finite_diff[1:-1], atol=2e-3)
    assert not track.sunlit.any()
    assert track.meta["refraction"] is False


def test_fixed_source_has_no_range():
    track = resolve("cyg a").observe(STATIONS[0], T0_S + np.arange(3.0))
    assert np.isnan(track.range_km).all() and np.isnan(track.range_rate_km_s).all()


@pytest.mark.parametrize("name", ["moon", "sun", "venus", "tau a"])
def test_rise_transit_set_match_pyephem_within_seconds(name):
    station = STATIONS[0]
    target = resolve(name)
    passes = find_passes(target, station, T0, datetime(2026, 8, 25, tzinfo=UTC))
    full = [p for p in passes if p.aos_known and p.los_known]
    assert len(full) >= 2
    o = _observer(station)
    body = _ephem_body(target)
    for p in full:
        rise = o.next_rising(body, start=_edate(p.aos.timestamp() - 3600), use_center=True)
        transit = o.next_transit(body, start=_edate(p.aos.timestamp()))
        setting = o.next_setting(body, start=_edate(p.los.timestamp() - 3600), use_center=True)
        assert abs(p.aos.timestamp() - _posix(rise)) < 3.0
        assert abs(p.tca.timestamp() - _posix(transit)) < 3.0
        assert abs(p.los.timestamp() - _posix(setting)) < 3.0
        # Invariants: on the horizon at rise/set, highest near transit.
        track = target.observe(station, np.array([p.aos.timestamp(), p.tca.timestamp(),
                                                  p.los.timestamp()]))
        assert np.allclose(track.el_deg[[0, 2]], 0.0, atol=0.01)
        assert track.el_deg[1] == pytest.approx(p.max_el_deg, abs=0.05)


def test_moon_pass_is_hours_long_and_fits_a_step_table():
    passes = find_passes(resolve("moon"), STATIONS[1], T0, T0_S + 86400)
    assert passes
    p = max(passes, key=lambda p: p.duration_s)
    assert 6 * 3600 < p.duration_s < 16 * 3600
    track = p.track(step_s=60.0)
    assert len(track) <= 1900  # one GS-232 W table
    assert track.t_s[0] == p.aos.timestamp() and track.t_s[-1] == p.los.timestamp()
    assert np.all(track.el_deg >= -0.01)


def test_circumpolar_sun_is_split_at_lower_culmination():
    station = Station("Nordaustlandet", 80.0, 20.0, 10.0)  # midnight sun until ~Aug 27
    passes = find_passes(resolve("sun"), station, T0, T0_S + 2 * 86400)
    assert len(passes) == 3
    assert not any(p.aos_known or p.los_known for p in passes)
    assert passes[0].aos.timestamp() == T0_S and passes[-1].los.timestamp() == T0_S + 2 * 86400
    for a, b in itertools.pairwise(passes):
        assert a.los.timestamp() == b.aos.timestamp()
    o = _observer(station)
    transit = _posix(o.next_transit(ephem.Sun(), start=_edate(T0_S)))
    assert abs(passes[0].tca.timestamp() - transit) < 3.0
    # The cut is at lower culmination: the Sun is due north there, at its lowest.
    cut = resolve("sun").observe(station, np.array([passes[0].los.timestamp()]))
    assert min(cut.az_deg[0], 360 - cut.az_deg[0]) < 0.5


def test_never_rising_target_gives_no_passes():
    # The Moon is near declination -28° in these days: never up at 78°N.
    assert find_passes(resolve("moon"), STATIONS[2], T0, T0_S + 2 * 86400) == []


def test_min_elevation_and_mask_delay_rise():
    sun = resolve("sun")
    base = find_passes(sun, STATIONS[0], T0, T0_S + 86400)[0]
    high = find_passes(sun, STATIONS[0], T0, T0_S + 86400, min_el_deg=10.0)[0]
    assert (high.aos.timestamp() > base.aos.timestamp() + 600
            and high.los.timestamp() < base.los.timestamp() - 600)
    el = sun.observe(STATIONS[0], np.array([high.aos.timestamp(), high.los.timestamp()])).el_deg
    assert np.allclose(el, 10.0, atol=0.01)
    # A 20° wall only in the east (where the Sun rises) delays the rise, not the set.
    mask = HorizonMask((0.0, 40.0, 50.0, 110.0, 120.0), (0.0, 0.0, 20.0, 20.0, 0.0))
    masked_station = Station("masked", 52.81, 6.40, 20.0, 0.0, mask)
    masked = find_passes(sun, masked_station, T0, T0_S + 86400)[0]
    assert masked.aos.timestamp() > base.aos.timestamp() + 1800
    assert masked.los.timestamp() == pytest.approx(base.los.timestamp(), abs=1.0)
    track = sun.observe(masked_station, np.array([masked.aos.timestamp()]))
    assert track.el_deg[0] == pytest.approx(masked_station.horizon_at(track.az_deg[0]),
                                            abs=0.01)


@pytest.mark.parametrize("text, kind", [("Sun", "sun"), ("MOON", "moon"), (" mars ", "planet"),
                                        ("Pluto", "planet"), ("Cas A", "radio"),
                                        ("cas-a", "radio"), ("CYG_A", "radio"),
                                        ("3C461", "radio"), ("Sgr A*", "radio"),
                                        ("radec:83.63,22.01", "radio")])
def test_names_are_case_and_separator_insensitive(text, kind):
    target = resolve(text)
    assert target is not None and target.kind == kind


def test_unknown_names_are_left_to_the_catalogue():
    assert resolve("ISS (ZARYA)") is None
    assert resolve("AO-91") is None


def test_missing_csv_is_reported_as_a_missing_schedule_file():
    with pytest.raises(ConfigError, match=r"cannot read schedule file /nonexistent/file\.csv"):
        resolve("/nonexistent/file.csv")


def test_radec_formats_agree():
    sexagesimal = parse_radec("radec:05:34:31.9,+22:00:52")
    degrees = parse_radec("RADEC:83.6329,22.0144")
    assert sexagesimal.ra_hours == pytest.approx(degrees.ra_hours, abs=1e-4)
    assert sexagesimal.dec_deg == pytest.approx(degrees.dec_deg, abs=1e-4)
    south = parse_radec("radec:17:45:40,-29:00:28")
    assert south.dec_deg == pytest.approx(-29.0078, abs=1e-4)


@pytest.mark.parametrize("bad", ["radec:", "radec:12", "radec:400,10", "radec:10,95",
                                 "radec:12:61:00,+10:00", "radec:ab,cd", "radec:-01:00:00,5"])
def test_bad_radec_says_the_format(bad):
    with pytest.raises(TargetError, match=r"radec:HH:MM:SS,\+DD:MM:SS"):
        resolve(bad)


def test_radio_sources_are_sane():
    names = {s.name for s in RADIO_SOURCES}
    assert {"Cas A", "Cyg A", "Tau A", "Vir A", "Sgr A"} <= names
    for s in RADIO_SOURCES:
        assert 0 <= s.ra_hours < 24 and -90 <= s.dec_deg <= 90


def test_event_labels_by_kind():
    assert event_labels("moon") == ("rise", "transit", "set")
    assert event_labels("radio") == ("rise", "transit", "set")
    assert event_labels("satellite") == ("AOS", "TCA", "LOS")


def test_resolver_is_registered_and_used_by_resolve_target():
    from tracker import targets

    assert resolve in targets.RESOLVERS
    resolve_target = getattr(targets, "resolve_target", None)
    if resolve_target is None:
        pytest.skip("tracker.targets.resolve_target not present")
    target = resolve_target("Moon", catalog=lambda: pytest.fail("catalogue loaded"))
    assert isinstance(target, SolarSystemTarget) and target.kind == "moon"


def test_missing_ephemeris_is_a_clear_config_error(monkeypatch, tmp_path):
    monkeypatch.setenv("TRACKER_EPHEMERIS", str(tmp_path / "nope.bsp"))
    with pytest.raises(ConfigError, match="TRACKER_EPHEMERIS"):
        resolve("sun").observe(STATIONS[0], np.array([T0_S]))


def test_missing_skyfield_data_says_how_to_install(monkeypatch):
    import sys

    monkeypatch.delenv("TRACKER_EPHEMERIS", raising=False)
    monkeypatch.setitem(sys.modules, "skyfield_data", None)  # import now raises ImportError
    with pytest.raises(ConfigError, match=r"pip install skyfield-data"):
        resolve("moon").observe(STATIONS[0], np.array([T0_S]))


def test_time_outside_de421_is_a_config_error():
    t_2100 = datetime(2100, 1, 1, tzinfo=UTC).timestamp()
    with pytest.raises(ConfigError, match="outside the ephemeris span 1899"):
        resolve("moon").observe(STATIONS[0], np.array([t_2100]))
