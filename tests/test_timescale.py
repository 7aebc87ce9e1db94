"""UTC text: ISO-8601 parse and format (tracker.timescale)."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from tracker.timescale import iso_utc, iso_utc_array, parse_iso_utc, utc_strftime

T = datetime(2026, 8, 22, 13, 45, 7, 250000, tzinfo=timezone.utc)


def test_iso_utc_rounds_to_the_second_with_z():
    assert iso_utc(T) == "2026-08-22T13:45:07Z"
    assert iso_utc(T.timestamp() + 0.5) == "2026-08-22T13:45:08Z"
    assert iso_utc(T, timespec="milliseconds") == "2026-08-22T13:45:07.250Z"


def test_iso_utc_array_matches_the_scalar_form():
    t = T.timestamp() + np.array([0.0, 0.49, 0.5, 0.51, 1.5, 2.5, -86400.0 * 400, 3.7e5])
    assert iso_utc_array(t).tolist() == [iso_utc(float(x)) for x in t]


@pytest.mark.parametrize("lo_s, hi_s", [
    (1.7e9, 1.7e9 + 7 * 86400.0),             # a batch window: one table per day and second
    (-30610224000.0, -30610224000.0 + 9e5),   # year 1000 (strftime pads no earlier year)
    (253402300799.0 - 9e5, 253402300799.0),   # year 9999
    (-30610224000.0, 253402300799.0),         # years apart: formatted one by one
])
def test_iso_utc_array_matches_the_scalar_form_over_the_calendar(lo_s, hi_s):
    t = np.random.default_rng(7).uniform(lo_s, hi_s, 2000).reshape(40, 50)
    got = iso_utc_array(t)
    assert got.shape == t.shape
    assert got.ravel().tolist() == [iso_utc(float(x)) for x in t.ravel()]


def test_iso_utc_array_of_nothing_and_of_no_time():
    assert iso_utc_array([]).tolist() == []
    assert iso_utc_array([np.nan, 0.0]).tolist() == ["NaTZ", "1970-01-01T00:00:00Z"]


@pytest.mark.parametrize("text", ["2026-08-22T13:45:07.25Z", "2026-08-22T13:45:07.25z",
                                  "2026-08-22T13:45:07.25", "2026-08-22T15:45:07.25+02:00",
                                  " 2026-08-22T13:45:07.250000+00:00 "])
def test_parse_iso_utc(text):
    t = parse_iso_utc(text)
    assert t == T and t.utcoffset() == (timedelta(hours=2) if "+02" in text else timedelta(0))


def test_parse_iso_utc_refuses_junk():
    with pytest.raises(ValueError):
        parse_iso_utc("yesterday")


def test_utc_strftime_truncates_like_a_clock():
    assert utc_strftime(T.timestamp() + 0.9, "%H:%M:%S") == "13:45:08"
    assert utc_strftime(T, "%Y-%m-%d %H:%M") == "2026-08-22 13:45"


def test_the_shared_timescale_is_skyfields_builtin_one_without_its_downloader():
    import numpy as np
    from skyfield.api import load

    from tracker.timescale import timescale

    ours, theirs = timescale(), load.timescale(builtin=True)
    assert np.array_equal(ours.leap_dates, theirs.leap_dates)
    assert np.array_equal(ours.leap_offsets, theirs.leap_offsets)
    seconds = np.linspace(-3e9, 3e9, 2001)
    a, b = ours.utc(2000, 1, 1, 0, 0, seconds), theirs.utc(2000, 1, 1, 0, 0, seconds)
    assert np.array_equal(a.tt, b.tt) and np.array_equal(a.dut1, b.dut1)
