"""TLE/3LE/OMM parsing on real files: the bundled snapshot and fixtures derived from it."""

from __future__ import annotations

import re
import warnings
from datetime import datetime, timedelta, timezone
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from _paths import DATA
from hypothesis import given
from hypothesis import strategies as st

from tle.alpha5 import alpha5_to_int, int_to_alpha5
from tle.checksum import compute_checksum
from tle.elements import ElementSet, load_file, parse_text, parse_tle_text, sniff_format
from tle.errors import TleError, TleFormatError, TleWarning
from tle.layout import LINE1_TEMPLATE, LINE2_TEMPLATE

TLE_DATA = DATA / "tle"
BUNDLED = Path(str(files("tle").joinpath("data")))
T0 = datetime(2026, 8, 23, tzinfo=timezone.utc)


def test_bundled_snapshot_parses_completely_with_checksums():
    counts = {p.stem: len(load_file(p)) for p in sorted(BUNDLED.glob("*.txt"))}
    assert counts == {"amateur": 96, "stations": 21, "visual": 157, "weather": 74}


def test_fields_of_a_real_set():
    (iss,) = [es for es in load_file(TLE_DATA / "amateur5.txt") if es.norad_id == 25544]
    assert iss.name == "ISS (ZARYA)"
    assert iss.intl_designator == "1998-067A"
    assert iss.line_no == 8 and iss.source.endswith("amateur5.txt")
    assert iss.line1.startswith("1 25544U") and iss.line2.startswith("2 25544 ")
    assert iss.omm is None and iss.group == "amateur5"
    sat = iss.satrec()
    # The epoch we compute from the columns agrees with sgp4's own (Julian date) epoch.
    sgp4_epoch = datetime(2000, 1, 1, 12, tzinfo=timezone.utc) + timedelta(
        days=(sat.jdsatepoch - 2451545.0) + sat.jdsatepochF)
    assert abs((iss.epoch - sgp4_epoch).total_seconds()) < 1e-3
    assert iss.mean_motion_rev_day == pytest.approx(15.49570248)


def test_epoch_year_pivot_and_age():
    (ao7,) = [es for es in load_file(TLE_DATA / "amateur5.txt") if es.norad_id == 7530]
    assert ao7.intl_designator == "1974-089B"  # 74 -> 1974, 26 -> 2026
    assert ao7.epoch.year == 2026
    assert ao7.age_days(ao7.epoch + timedelta(days=3)) == pytest.approx(3.0)
    with pytest.raises(TleError, match="aware"):
        ao7.age_days(datetime(2026, 8, 25))


def test_messy_layout_lf_blank_lines_zero_names_trailing_blanks_2le():
    clean = load_file(TLE_DATA / "amateur5.txt")
    messy = load_file(TLE_DATA / "messy.txt")
    assert [(e.line1, e.line2) for e in messy] == [(e.line1, e.line2) for e in clean]
    assert [e.name for e in messy] == ["OSCAR 7 (AO-7)", "14129", "ISS (ZARYA)",
                                       "SAUDISAT 1C (SO-50)", "FUNCUBE-1 (AO-73)"]


def test_crlf_and_lf_give_identical_sets():
    crlf = (TLE_DATA / "amateur5.txt").read_bytes()
    assert b"\r\n" in crlf
    a = parse_tle_text(crlf.decode())
    b = parse_tle_text(crlf.decode().replace("\r\n", "\n"))
    assert a == b and len(a) == 5


def test_bad_checksum_names_file_line_and_digits():
    with pytest.raises(TleFormatError, match=re.escape(
            "bad_checksum.txt:5: 'ISS (ZARYA)' line 1: checksum expected 7, found 3")) as info:
        load_file(TLE_DATA / "bad_checksum.txt")
    assert info.value.line_no == 5 and info.value.line.startswith("1 25544U")
    assert "\n" not in str(info.value)


def test_shifted_column_shows_the_layout():
    with pytest.raises(TleFormatError) as info:
        load_file(TLE_DATA / "shifted_column.txt")
    message = str(info.value)
    assert re.search(re.escape("shifted_column.txt:5: 'ISS (ZARYA)' line 1: column 24 "
                               "should be '.', found '4'"), message)
    assert message.endswith(f"line 1 layout: {LINE1_TEMPLATE}")


def test_truncated_line2():
    with pytest.raises(TleFormatError, match=re.escape(
            "truncated_line2.txt:6: 'ISS (ZARYA)' line 2: 50 characters long, expected 69 "
            f"(truncated?); line 2 layout: {LINE2_TEMPLATE}")):
        load_file(TLE_DATA / "truncated_line2.txt")


def test_line1_and_line2_catalogue_numbers_must_match():
    with pytest.raises(TleFormatError, match=re.escape(
            "mismatched_ids.txt:6: 'ISS (ZARYA)' line 2: catalogue number '25545' does not "
            "match line 1's '25544'")):
        load_file(TLE_DATA / "mismatched_ids.txt")


@pytest.mark.parametrize("name", ["bad_checksum.txt", "shifted_column.txt",
                                  "truncated_line2.txt", "mismatched_ids.txt"])
def test_skip_bad_gives_one_warning_per_bad_set(name):
    seen: list[str] = []
    sets = load_file(TLE_DATA / name, skip_bad=True, on_warning=seen.append)
    assert [es.norad_id for es in sets] == [7530, 39444]
    assert len(seen) == 1 and f"{name}:" in seen[0] and "ISS (ZARYA)" in seen[0]


def test_skip_bad_without_callback_uses_warnings():
    with pytest.warns(TleWarning, match="checksum expected 7, found 3"):
        sets = load_file(TLE_DATA / "bad_checksum.txt", skip_bad=True)
    assert len(sets) == 2


@pytest.mark.parametrize(("text", "message"), [
    ("ISS\nNOT A TLE\n", "<string>:1: name line 'ISS' is not followed by a line 1"),
    (None, "<string>:1: line 2: line 2 without a line 1 before it"),
    (None, "<string>:3: 'ISS (ZARYA)' line 1: is not followed by a line 2"),
])
def test_structure_errors(text, message):
    lines = (TLE_DATA / "amateur5.txt").read_text().splitlines()
    if text is None and "without a line 1" in message:
        text = "\n".join([lines[2], lines[3], lines[4], lines[5]])
    elif text is None:
        text = "\n".join(["", lines[6], lines[7], lines[9], lines[10], lines[11]])
    with pytest.raises(TleFormatError, match=re.escape(message)):
        parse_tle_text(text)


def test_empty_text_is_no_sets():
    assert parse_tle_text("\r\n  \n") == []


def test_checksum_counts_minus_as_one():
    assert compute_checksum("1 -" + "0" * 66) == 2  # '1' + '-'
    for line in (TLE_DATA / "amateur5.txt").read_text().splitlines():
        if line[:2] in ("1 ", "2 "):
            assert compute_checksum(line) == int(line[68])


@given(st.text(max_size=80))
def test_checksum_is_the_digit_sum_of_the_first_68_columns(line):
    # the definition, character by character (only ASCII digits and '-' count)
    expected = sum(int(c) if c in "0123456789" else c == "-" for c in line[:68]) % 10
    assert compute_checksum(line) == expected


@pytest.mark.parametrize(("field", "norad_id"), [
    ("00005", 5), ("25544", 25544), ("99999", 99999), ("A0000", 100000), ("H9999", 179999),
    ("J0000", 180000), ("N9999", 229999), ("P0000", 230000), ("Z9999", 339999),
])
def test_alpha5_table(field, norad_id):
    assert alpha5_to_int(field) == norad_id
    assert int_to_alpha5(norad_id) == field


@pytest.mark.parametrize("field", ["I0000", "O1234", "A12", "12a45", "     "])
def test_alpha5_rejects(field):
    with pytest.raises(ValueError):
        alpha5_to_int(field)


@given(st.integers(min_value=0, max_value=339_999))
def test_alpha5_round_trip(norad_id):
    assert alpha5_to_int(int_to_alpha5(norad_id)) == norad_id


def test_alpha5_file_agrees_with_sgp4():
    low, high = load_file(TLE_DATA / "alpha5.txt")
    assert (low.norad_id, high.norad_id) == (100000, 339999)
    assert low.satrec().satnum == 100000 and high.satrec().satnum == 339999


def test_alpha5_letter_i_is_a_layout_error():
    lines = (TLE_DATA / "alpha5.txt").read_text().splitlines()[:3]
    l1 = lines[1][:2] + "I0000" + lines[1][7:68]
    l2 = lines[2][:2] + "I0000" + lines[2][7:68]
    text = "\n".join([lines[0], l1 + str(compute_checksum(l1)), l2 + str(compute_checksum(l2))])
    with pytest.raises(TleFormatError, match=re.escape("line 1: columns 3-7: catalogue number "
                                                       "'I0000' is neither 5 digits nor Alpha-5")):
        parse_tle_text(text)


@pytest.mark.parametrize("suffix", ["json", "csv", "xml"])
def test_omm_forms_match_the_tle_within_metres(suffix):
    tle_sets = load_file(TLE_DATA / "amateur5.txt")
    omm_sets = load_file(TLE_DATA / f"amateur5.{suffix}")
    assert [(e.name, e.norad_id, e.intl_designator) for e in omm_sets] == \
        [(e.name, e.norad_id, e.intl_designator) for e in tle_sets]
    jd = np.full(4, 2461275.5)  # 2026-08-23 00:00 UTC
    fr = np.array([0.0, 0.25, 1.0, 3.0])
    for a, b in zip(tle_sets, omm_sets, strict=True):
        assert b.line1 is None and b.omm["NORAD_CAT_ID"] == str(a.norad_id)
        assert abs((a.epoch - b.epoch).total_seconds()) < 1e-3
        ea, ra, _ = a.satrec().sgp4_array(jd, fr)
        eb, rb, _ = b.satrec().sgp4_array(jd, fr)
        assert not ea.any() and not eb.any()
        distance_km = np.linalg.norm(ra - rb, axis=1)
        assert distance_km.max() < 0.01, (a.name, distance_km)


def test_earth_satellite_keeps_the_name_for_tle_and_omm():
    from skyfield.api import load

    ts = load.timescale(builtin=True)
    for path in (TLE_DATA / "amateur5.txt", TLE_DATA / "amateur5.json"):
        iss = next(es for es in load_file(path) if es.norad_id == 25544)
        sat = iss.earth_satellite(ts)
        assert sat.name == "ISS (ZARYA)" and sat.model.satnum == 25544


def test_sniffing():
    assert sniff_format((TLE_DATA / "amateur5.json").read_text()) == "json"
    assert sniff_format((TLE_DATA / "amateur5.csv").read_text()) == "csv"
    assert sniff_format((TLE_DATA / "amateur5.xml").read_text()) == "xml"
    assert sniff_format((TLE_DATA / "amateur5.txt").read_text()) == "tle"
    assert sniff_format("<!DOCTYPE html><html><body>502</body></html>") == "html"
    with pytest.raises(TleFormatError, match="HTML page, not element sets"):
        parse_text("<html><head><title>Error</title></head></html>", source="x")


def test_omm_missing_and_bad_fields(tmp_path):
    import json

    records = json.loads((TLE_DATA / "amateur5.json").read_text())
    del records[1]["MEAN_MOTION"]
    records[2]["ECCENTRICITY"] = "zero"
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(records))
    with pytest.raises(TleFormatError, match=re.escape(
            "broken.json:record 2 ('PHASE 3B (AO-10)'): missing OMM field(s) MEAN_MOTION")):
        load_file(path)
    seen: list[str] = []
    sets = load_file(path, skip_bad=True, on_warning=seen.append)
    assert len(sets) == 3 and len(seen) == 2
    assert "ECCENTRICITY should be a number, found 'zero'" in seen[1]


def test_omm_csv_row_numbers_and_bad_xml(tmp_path):
    rows = (TLE_DATA / "amateur5.csv").read_text().splitlines()
    rows[3] = rows[3].replace("2026-08-22T", "22/08/2026 ")
    path = tmp_path / "broken.csv"
    path.write_text("\n".join(rows))
    with pytest.raises(TleFormatError, match=re.escape("broken.csv:line 4 ('ISS (ZARYA)'): "
                                                       "EPOCH should look like")):
        load_file(path)
    xml = tmp_path / "broken.xml"
    xml.write_text((TLE_DATA / "amateur5.xml").read_text()[:700])
    with pytest.raises(TleFormatError, match=r"broken\.xml:.*not well-formed XML"):
        load_file(xml)


def test_unreadable_and_binary_files(tmp_path):
    with pytest.raises(TleError, match="cannot read element file"):
        load_file(tmp_path / "missing.txt")
    blob = tmp_path / "blob.txt"
    blob.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(TleFormatError, match="not a text file"):
        load_file(blob)


def test_element_sets_are_hashable_values():
    a = load_file(TLE_DATA / "amateur5.json")
    assert len(set(a)) == 5
    assert isinstance(a[0], ElementSet)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert parse_tle_text((TLE_DATA / "amateur5.txt").read_text(), skip_bad=True)
