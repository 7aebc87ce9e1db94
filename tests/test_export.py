"""CSV / JSON / iCalendar export of pass lists, and atomic writes."""

from __future__ import annotations

import csv
import io
import json
import os
import stat
from datetime import datetime, timedelta, timezone

import icalendar
import numpy as np
import pytest
from _paths import REPO
from sgp4.api import Satrec

from tracker.batch import find_passes_batch
from tracker.errors import ConfigError
from tracker.export import (
    CSV_FIELDS,
    JSON_SCHEMA_ID,
    pass_records,
    pass_uid,
    to_csv,
    to_ics,
    to_json,
    to_table,
)
from tracker.files import write_atomic
from tracker.station import Station

START = datetime(2026, 8, 22, 13, 45, tzinfo=timezone.utc)


@pytest.fixture(scope="module")
def table():
    path = REPO / "tle" / "data" / "amateur.txt"
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip()]
    sets = [(lines[i], lines[i + 1], lines[i + 2]) for i in range(0, 30, 3)]
    # A name with every character RFC 5545 escapes, to exercise escaping end to end.
    names = [n for n, _, _ in sets]
    names[0] = 'ODD; NAME, WITH \\ "ALL"'
    return find_passes_batch([Satrec.twoline2rv(a, b) for _, a, b in sets], names,
                             [Station("Delft; NL", 52.0, 4.37, 10.0)], START,
                             START + timedelta(days=1))


@pytest.fixture(scope="module")
def records(table):
    plans = [{"mode": "flip", "max_error_deg": 1.25, "preposition_s": float(p["aos_s"]) - 40,
              "reason": "Flip: over the top, avoiding the north stop."}
             if i % 2 == 0 else None for i, p in enumerate(table.passes)]
    return pass_records(table, plans)


def test_csv_round_trips(records):
    rows = list(csv.DictReader(io.StringIO(to_csv(records))))
    assert len(rows) == len(records) > 10
    assert tuple(rows[0]) == CSV_FIELDS
    for row, rec in zip(rows, records, strict=True):
        assert row["satellite"] == rec["satellite"]
        assert datetime.fromisoformat(row["aos"].replace("Z", "+00:00")).timestamp() == \
            pytest.approx(rec["aos_s"], abs=0.5)
        assert float(row["max_el_deg"]) == rec["max_el_deg"]
        assert row["sunlit"] in ("true", "false")
        assert row["plan_mode"] == ("flip" if rec["plan"] else "")


def test_json_follows_the_documented_schema(records):
    doc = json.loads(to_json(records, {"source": "amateur"}, [{"satellite": "X", "code": 6,
                                                               "message": "decayed",
                                                               "from": "2026-08-23T00:00:00Z"}]))
    assert doc["schema"] == JSON_SCHEMA_ID
    assert doc["meta"]["source"] == "amateur" and doc["errors"][0]["code"] == 6
    schema_doc = (REPO / "docs" / "batch-json-schema.md").read_text()
    for p in doc["passes"]:
        for key, value in p.items():
            assert f"`{key}`" in schema_doc, f"{key} is not documented"
            if key == "plan" and value:
                assert set(value) == {"mode", "max_error_deg", "preposition", "reason"}
        assert p["aos_s"] <= p["tca_s"] <= p["los_s"]


def test_ics_is_valid_rfc5545_and_parses_back(records):
    text = to_ics(records, START.timestamp(), "Amateur passes")
    assert all(len(line.encode()) <= 75 for line in text.split("\r\n"))
    assert "\n" not in text.replace("\r\n", "")
    cal = icalendar.Calendar.from_ical(text)
    events = [c for c in cal.walk() if c.name == "VEVENT"]
    assert len(events) == len(records)
    for ev, rec in zip(events, records, strict=True):
        assert ev["DTSTART"].dt == datetime.fromtimestamp(round(rec["aos_s"]), timezone.utc)
        assert ev["DTEND"].dt == datetime.fromtimestamp(round(rec["los_s"]), timezone.utc)
        assert str(ev["SUMMARY"]) == f"{rec['satellite']} max {rec['max_el_deg']:.0f}°"
        assert str(ev["LOCATION"]) == rec["station"]
        desc = str(ev["DESCRIPTION"])
        assert desc.splitlines()[0] == f"{rec['satellite']} from {rec['station']}"
        if rec["plan"]:
            assert "plan: flip, predicted max error 1.25 deg" in desc
        assert str(ev["UID"]) == pass_uid(rec)
    assert len({str(e["UID"]) for e in events}) == len(events)
    # Same input, same bytes (DTSTAMP is the run's "as of" time, UIDs are stable).
    assert to_ics(records, START.timestamp(), "Amateur passes") == text


def test_table_lists_every_pass(records):
    lines = to_table(records).splitlines()
    assert len(lines) == len(records) + 2 and "max el" in lines[0]


def test_write_atomic_never_truncates_on_error(tmp_path):
    out = tmp_path / "passes.csv"
    write_atomic(out, "first\n")
    assert out.read_text() == "first\n"

    with pytest.raises(TypeError):
        write_atomic(out, 12345)  # type: ignore[arg-type]  # write() fails mid-way
    assert out.read_text() == "first\n"
    assert [p.name for p in tmp_path.iterdir()] == ["passes.csv"]  # no temp file left
    write_atomic(out, "second\r\n", force=True)
    assert out.read_bytes() == b"second\r\n"
    with pytest.raises(ConfigError, match="does not exist"):
        write_atomic(tmp_path / "nope" / "x.csv", "x")


def test_write_atomic_failed_rename_keeps_what_is_there(tmp_path):
    # The destination is a folder holding a file: the final rename fails (as root too), the
    # folder and its content are untouched and no temporary file is left behind.
    dest = tmp_path / "out.csv"
    dest.mkdir()
    (dest / "keep.txt").write_text("keep\n")
    with pytest.raises(ConfigError, match="is a directory, not a regular file"):
        write_atomic(dest, "new\n", force=True)
    assert (dest / "keep.txt").read_text() == "keep\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_records_carry_clipping_and_flags(table, records):
    assert [r["aos_clipped"] for r in records] == table.passes["aos_clipped"].tolist()
    assert np.array_equal([r["sunlit"] for r in records], table.passes["sunlit"])


def test_clipped_passes_say_so_in_the_calendar(records):
    clipped = [r for r in records if r["aos_clipped"] or r["los_clipped"]]
    assert clipped  # a one-day window over GEO/long passes cuts some at the edges
    cal = icalendar.Calendar.from_ical(to_ics(records, START.timestamp()))
    by_uid = {str(e["UID"]): str(e["DESCRIPTION"]) for e in cal.walk("VEVENT")}
    for rec in records:
        desc = by_uid[pass_uid(rec)]
        assert ("already up at the window start" in desc) == rec["aos_clipped"]
        assert ("still up at the window end" in desc) == rec["los_clipped"]


def test_write_atomic_gives_normal_file_permissions(tmp_path):
    # mkstemp creates 0600 files; the output must get what open() would give instead, and an
    # existing file keeps its own mode.
    umask = os.umask(0o022)
    try:
        fresh = write_atomic(tmp_path / "new.ics", "x\r\n")
        assert stat.S_IMODE(fresh.stat().st_mode) == 0o644
        kept = tmp_path / "kept.csv"
        kept.write_text("old\n")
        kept.chmod(0o640)
        write_atomic(kept, "new\n", force=True)
        assert stat.S_IMODE(kept.stat().st_mode) == 0o640 and kept.read_text() == "new\n"
    finally:
        os.umask(umask)
