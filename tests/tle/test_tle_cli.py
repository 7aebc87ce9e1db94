"""``tracker tle update|list|show`` end to end, against a real local HTTP server."""

from __future__ import annotations

import re

import pytest
from _paths import DATA

from tracker.cli import main

TLE_DATA = DATA / "tle"
AT = "2026-08-25T00:00Z"


def one_line_error(capsys) -> str:
    """The one error line (warnings may come before it), with no traceback."""
    lines = capsys.readouterr().err.splitlines()
    errors = [line for line in lines if line.startswith("tracker: error: ")]
    assert len(errors) == 1 and lines[-1] == errors[0], lines
    assert not any("Traceback" in line for line in lines)
    return errors[0]


def test_list_and_show_on_the_bundled_snapshot(cache, capsys):
    assert main(["tle", "list", "--at", AT]) == 0
    out = capsys.readouterr().out
    assert "no cached elements" in out and "bundled snapshot" in out
    assert re.search(r"amateur\s+96\s+2\.\d d", out)
    assert main(["tle", "show", "ISS", "--at", "2026-09-05T00:00Z"]) == 0
    captured = capsys.readouterr()
    assert "ISS (ZARYA)  (NORAD 25544, 1998-067A)" in captured.out
    assert "13.50 days old" in captured.out
    assert "1 25544U 98067A   26234.50053383" in captured.out
    assert "tracker: warning: elements for ISS (ZARYA) are 13.5 days old" in captured.err
    assert "bundled element snapshot" in captured.err
    assert main(["tle", "show", "ISS", "--at", "2026-10-05T00:00Z"]) == 0
    err = capsys.readouterr().err
    assert "tracker: WARNING: elements for ISS (ZARYA) are 43 days old" in err  # louder, once


def test_update_then_list_then_show_from_cache(cache, capsys, celestrak):
    celestrak.behaviour["weather"] = "json"
    assert main(["tle", "update", "amateur", "weather", "--base-url", celestrak.base_url,
                 "--at", AT]) == 0
    out = capsys.readouterr().out
    assert re.search(r"amateur\s+updated\s+5 sets", out)
    assert (cache / "amateur.txt").is_file() and (cache / "weather.json").is_file()
    # Within 2 hours the next update sends nothing.
    assert main(["tle", "update", "amateur", "--base-url", celestrak.base_url,
                 "--at", AT]) == 0
    assert "fresh" in capsys.readouterr().out and len(celestrak.requests) == 2
    assert main(["tle", "list", "--at", "2026-08-25T01:00Z"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"amateur\s+5\s+1\.0 h\s+2\.\d d\s+http://127\.0\.0\.1", out)
    assert main(["tle", "show", "AO-7", "--at", AT]) == 0
    captured = capsys.readouterr()
    assert "OSCAR 7 (AO-7)" in captured.out and "amateur.txt:2" in captured.out
    assert captured.err == ""


def test_update_uses_env_base_url(cache, capsys, celestrak, monkeypatch):
    monkeypatch.setenv("TRACKER_CELESTRAK_URL", celestrak.base_url)
    assert main(["tle", "update", "stations", "--at", AT]) == 0
    assert celestrak.requests[0][0] == "stations"


@pytest.mark.parametrize(("how", "pattern"), [
    ("404", r"HTTP 404 Not Found; cached copy kept"),
    ("html", r"is an HTML page, not element sets"),
    ("cut", r"truncated download"),
])
def test_update_errors_are_one_line(cache, capsys, celestrak, how, pattern):
    celestrak.behaviour["amateur"] = how
    assert main(["tle", "update", "amateur", "--base-url", celestrak.base_url]) == 2
    assert re.search(pattern, one_line_error(capsys))


def test_update_without_network(cache, capsys):
    assert main(["tle", "update", "--base-url", "http://127.0.0.1:9/gp.php",
                 "--timeout", "2"]) == 2
    err = one_line_error(capsys)
    assert "4 of 4 sources failed (amateur, weather, stations, visual), cached copies kept" in err
    assert "no network?" in err


def test_show_unknown_and_ambiguous(cache, capsys):
    assert main(["tle", "show", "ISSS"]) == 2
    assert "did you mean 'ISS (ZARYA)'" in one_line_error(capsys)
    assert main(["tle", "show", "NOAA"]) == 2
    assert "matches 2 satellites" in one_line_error(capsys)


def test_show_from_a_file_skips_bad_sets(cache, capsys):
    assert main(["tle", "show", "AO-73", "--tle", str(TLE_DATA / "bad_checksum.txt"),
                 "--at", AT]) == 0
    captured = capsys.readouterr()
    assert "FUNCUBE-1 (AO-73)" in captured.out
    assert captured.err.count("checksum expected 7, found 3") == 1
    assert main(["tle", "show", "ISS", "--tle", str(TLE_DATA / "bad_checksum.txt")]) == 2
    assert "no satellite 'ISS'" in one_line_error(capsys)


def test_show_omm_file(cache, capsys):
    assert main(["tle", "show", "25544", "--tle", str(TLE_DATA / "amateur5.xml"), "--at", AT]) == 0
    out = capsys.readouterr().out
    assert "MEAN_MOTION        15.49570248" in out and "amateur5.xml:3" in out


def test_bad_group_name(cache, capsys):
    assert main(["tle", "update", "no such group"]) == 2
    assert "neither a CelesTrak group name" in one_line_error(capsys)


def test_one_updated_group_hides_no_bundled_one(cache, capsys, celestrak):
    assert main(["tle", "update", "amateur", "--base-url", celestrak.base_url,
                 "--at", AT]) == 0
    capsys.readouterr()
    assert main(["tle", "show", "NOAA-20", "--at", AT]) == 0
    assert "NOAA 20 (JPSS-1)" in capsys.readouterr().out
    assert main(["passes", "--group", "weather", "--hours", "1", "--at", AT,
                 "--lat", "52", "--lon", "4"]) == 0
    capsys.readouterr()
    assert main(["tle", "list", "--at", AT]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^amateur\s+\d+\s+[\d.]+ d\s+bundled \+ cache$", out, re.M), out
    assert re.search(r"^weather\s+\d+\s+[\d.]+ d\s+bundled$", out, re.M), out
