"""Station and horizon mask: validation, file loading with file:line errors, interpolation."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.errors import ConfigError
from tracker.station import HorizonMask, Station, locator_lat_lon, position_name


def test_station_ranges_named_in_errors():
    with pytest.raises(ConfigError, match=r"lat_deg = 95.0 is out of range; allowed: -90 to 90"):
        Station("x", 95.0, 0.0)
    with pytest.raises(ConfigError, match="min_el_deg"):
        Station("x", 10.0, 0.0, min_el_deg=91)
    with pytest.raises(ConfigError, match="lon_deg"):
        Station("x", 10.0, float("nan"))


def test_mask_file_interpolates_and_wraps(tmp_path):
    f = tmp_path / "mask.txt"
    f.write_text("# bearing elevation\n0 10\n90, 20   # trees\n\n270\t0\n")
    mask = HorizonMask.load(f)
    assert mask.az_deg == (0.0, 90.0, 270.0)
    assert mask.min_el_at(45.0) == pytest.approx(15.0)
    assert mask.min_el_at(315.0) == pytest.approx(5.0)  # wraps 270 -> 360(=0)
    assert mask.min_el_at(-45.0) == pytest.approx(5.0)
    st = Station("x", 52.0, 4.4, min_el_deg=8.0, mask=mask)
    np.testing.assert_allclose(st.horizon_at(np.array([0.0, 45.0, 270.0])), [10.0, 15.0, 8.0])
    assert isinstance(st.horizon_at(45.0), float)


@pytest.mark.parametrize(("text", "what"), [
    ("0 10\n90 abc\n", ":2: expected 'azimuth_deg elevation_deg'"),
    ("0 10\n400 5\n", ":2: azimuth must be 0-360"),
    ("0 10 5\n", ":1: expected"),
    ("# nothing\n", "has no points"),
])
def test_bad_mask_files_name_the_line(tmp_path, text, what):
    f = tmp_path / "mask.txt"
    f.write_text(text)
    with pytest.raises(ConfigError) as e:
        HorizonMask.load(f)
    assert str(e.value).startswith(str(f))
    assert what in str(e.value)


def test_missing_mask_file(tmp_path):
    with pytest.raises(ConfigError, match="cannot read horizon mask"):
        HorizonMask.load(tmp_path / "nope.txt")


def test_topos_matches_station():
    st = Station("x", 52.0, 4.4, 12.0)
    topos = st.topos()
    assert topos.latitude.degrees == pytest.approx(52.0)
    assert topos.longitude.degrees == pytest.approx(4.4)
    assert topos.elevation.m == pytest.approx(12.0)


def test_parse_station_one_schema_two_spellings(tmp_path):
    from tracker.station import parse_station

    (tmp_path / "m.txt").write_text("0 5\n")
    full = parse_station({"name": "A", "lat_deg": 10, "lon_deg": 20, "alt_m": 5,
                          "min_el_deg": 3, "mask": "m.txt"}, "f:", base_dir=tmp_path)
    short = parse_station({"NAME": "A", "lat": "10", "lon": "20", "alt": "5", "min_el": "3",
                           "mask": str(tmp_path / "m.txt")}, "f:", from_text=True)
    assert full == short and full.mask is not None
    assert parse_station({"lat_deg": 1, "lon_deg": 2}, "f:", default_name="home").name == "home"


@pytest.mark.parametrize(("values", "message"), [
    ({"name": "A", "lat_deg": "10", "lon_deg": 2}, 'f: lat_deg = "10" is invalid; allowed: a '
                                                   'number from -90 to 90'),
    ({"name": "A", "lat_deg": True, "lon_deg": 2}, "f: lat_deg = true is invalid"),
    ({"name": "A", "lat": 91, "lon_deg": 2}, "f: lat = 91 is invalid"),
    ({"name": " ", "lat_deg": 1, "lon_deg": 2}, 'f: name = " " is invalid'),
    ({"name": "A", "lat_deg": 1}, "f: lon_deg is missing; add e.g. lon_deg = 4.4"),
    ({"lat_deg": 1, "lon_deg": 2}, "f: name is missing"),
    ({"name": "A", "lat_deg": 1, "lon_deg": 2, "height": 3}, "f: unknown key 'height'"),
    ({"name": "A", "lat_deg": 1, "lon_deg": 2, "mask": 3}, "f: mask = 3 is invalid"),
])
def test_parse_station_errors(values, message):
    from tracker.station import parse_station

    with pytest.raises(ConfigError) as e:
        parse_station(values, "f:")
    assert message in str(e.value)


@pytest.mark.parametrize(("locator", "lat_deg", "lon_deg"), [
    ("JO", 55.0, 10.0),                    # a 10 x 20 degree field: its centre
    ("JO22", 52.5, 5.0),
    ("jo22xb", 52.0 + 1.5 / 24, 4.0 + 47 / 24),
    ("FN31pr", 41.72917, -72.70833),       # W1AW
    ("JO22XB45", 52.0 + 1 / 24 + 5.5 / 240, 4.0 + 46 / 24 + 9 / 240),
    ("RR99xx99", 89.99792, 179.99583),
    ("AA00aa00", -89.99792, -179.99583),
])
def test_maidenhead_locator_centres(locator, lat_deg, lon_deg):
    assert locator_lat_lon(locator) == pytest.approx((lat_deg, lon_deg), abs=1e-4)


@pytest.mark.parametrize(("locator", "message"), [
    ("JO2", "must have 2, 4, 6 or 8 characters"),
    ("", "must have 2, 4, 6 or 8 characters"),
    ("SA22", r"character 1 \('S'\) must be a letter A-R"),
    ("JOX2", r"character 3 \('X'\) must be a digit"),
    ("JO22yb", r"character 5 \('Y'\) must be a letter A-X"),
    ("JO22xb4a", r"character 8 \('A'\) must be a digit"),
])
def test_bad_locators_say_what_is_wrong(locator, message):
    with pytest.raises(ConfigError, match=message):
        locator_lat_lon(locator)


def test_position_name_is_readable():
    assert position_name(52.0, 4.4) == "52.0000N 4.4000E"
    assert position_name(-33.9, -18.25) == "33.9000S 18.2500W"


def test_parse_station_takes_a_locator_for_the_position():
    from tracker.station import parse_station

    st = parse_station({"name": "A", "locator": "JO22"}, "f:")
    assert (st.lat_deg, st.lon_deg) == pytest.approx((52.5, 5.0))
    with pytest.raises(ConfigError, match="f: has both locator and lat_deg/lon_deg"):
        parse_station({"name": "A", "locator": "JO22", "lat": 1}, "f:")
    with pytest.raises(ConfigError, match="f: Maidenhead locator 'JO2'"):
        parse_station({"name": "A", "locator": "JO2"}, "f:")
