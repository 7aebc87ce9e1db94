"""Station and horizon mask: validation, file loading with file:line errors, interpolation."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.errors import ConfigError
from tracker.station import HorizonMask, Station


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
