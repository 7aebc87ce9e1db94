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
    PASS_FIELDS,
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
    text = to_csv(records)
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == len(records) > 10
    assert tuple(rows[0]) == CSV_FIELDS
    assert any(r["target"] == 'ODD; NAME, WITH \\ "ALL"' for r in rows)  # quoted
    for row, rec in zip(rows, records.rows(), strict=True):
        assert row["target"] == rec["target"]
        assert datetime.fromisoformat(row["aos"].replace("Z", "+00:00")).timestamp() == \
            pytest.approx(rec["aos_s"], abs=0.5)
        assert float(row["max_el_deg"]) == rec["max_el_deg"]
        assert row["sunlit"] in ("true", "false")
        assert row["plan_mode"] == (rec["plan_mode"] or "")
        assert row["aos_known"] == ("true" if rec["aos_known"] else "false")
        assert row["priority"] == ""


def _csv_module_text(records) -> str:
    """What the csv module writes for the records (flags as true/false)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_FIELDS)
    for rec in records.rows():
        w.writerow([("true" if v else "false") if isinstance(v, bool) else v
                    for v in (rec[k] for k in CSV_FIELDS)])
    return buf.getvalue()


def test_csv_is_what_the_csv_module_writes(records):
    # The column-wise writer must quote exactly as csv.writer does.
    records.set("priority", range(len(records)))
    records.set("chosen", (i % 2 == 0 for i in range(len(records))))
    try:
        assert to_csv(records) == _csv_module_text(records)
    finally:
        records.set("priority", [None] * len(records))
        records.set("chosen", [None] * len(records))


def test_single_target_passes_give_the_same_record():
    from tle.catalog import Catalog
    from tracker.passes import find_passes
    from tracker.targets import SatelliteTarget

    iss = SatelliteTarget(Catalog.bundled_snapshot().find("ISS (ZARYA)"))
    station = Station("Delft", 52.0, 4.37, 10.0)
    passes = find_passes(iss, station, START, START + timedelta(days=1))
    recs = pass_records(passes)
    assert len(recs) == len(passes) > 0
    for rec, p in zip(recs.rows(), passes, strict=True):
        assert tuple(rec) == PASS_FIELDS
        assert rec["target"] == "ISS (ZARYA)" and rec["station"] == "Delft"
        assert rec["aos_s"] == p.aos.timestamp() and rec["aos"].endswith("Z")
        assert rec["aos_known"] == p.aos_known and rec["always_up"] == p.always_up
        assert rec["aos_az_deg"] == round(p.aos_az_deg, 1)
        assert rec["plan_mode"] is None and rec["priority"] is None


def test_json_follows_the_documented_schema(records):
    doc = json.loads(to_json(records, {"source": "amateur"}, [{"satellite": "X", "code": 6,
                                                               "message": "decayed",
                                                               "from": "2026-08-23T00:00:00Z"}]))
    assert doc["schema"] == JSON_SCHEMA_ID
    assert doc["meta"]["source"] == "amateur" and doc["errors"][0]["code"] == 6
    schema_doc = (REPO / "docs" / "pass-schema.md").read_text()
    assert f"`{JSON_SCHEMA_ID}`" in schema_doc
    assert [tuple(p) for p in doc["passes"]] == [PASS_FIELDS] * len(records)
    for key in PASS_FIELDS:
        assert f"`{key}`" in schema_doc, f"{key} is not documented"
    for p in doc["passes"]:
        assert p["aos_s"] <= p["tca_s"] <= p["los_s"]


def test_ics_is_valid_rfc5545_and_parses_back(records):
    text = to_ics(records, START.timestamp(), "Amateur passes")
    assert all(len(line.encode()) <= 75 for line in text.split("\r\n"))
    assert "\n" not in text.replace("\r\n", "")
    cal = icalendar.Calendar.from_ical(text)
    events = [c for c in cal.walk() if c.name == "VEVENT"]
    assert len(events) == len(records)
    for ev, rec in zip(events, records.rows(), strict=True):
        assert ev["DTSTART"].dt == datetime.fromtimestamp(round(rec["aos_s"]), timezone.utc)
        assert ev["DTEND"].dt == datetime.fromtimestamp(round(rec["los_s"]), timezone.utc)
        assert str(ev["SUMMARY"]) == f"{rec['target']} max {rec['max_el_deg']:.0f}°"
        assert str(ev["LOCATION"]) == rec["station"]
        desc = str(ev["DESCRIPTION"])
        assert desc.splitlines()[0] == f"{rec['target']} from {rec['station']}"
        if rec["plan_mode"]:
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
    assert np.array_equal(records["aos_known"], ~table.passes["aos_clipped"])
    assert np.array_equal(records["los_known"], ~table.passes["los_clipped"])
    assert np.array_equal(records["in_progress_at_start"], table.passes["aos_clipped"])
    assert np.array_equal(records["always_up"],
                          table.passes["aos_clipped"] & table.passes["los_clipped"])
    assert np.array_equal(records["sunlit"], table.passes["sunlit"])
    assert records.take([1, 0])["aos_s"].tolist() == records["aos_s"][[1, 0]].tolist()
    assert len(records.take([])) == 0


def test_clipped_passes_say_so_in_the_calendar(records):
    clipped = [r for r in records.rows() if not (r["aos_known"] and r["los_known"])]
    assert clipped  # a one-day window over GEO/long passes cuts some at the edges
    cal = icalendar.Calendar.from_ical(to_ics(records, START.timestamp()))
    by_uid = {str(e["UID"]): str(e["DESCRIPTION"]) for e in cal.walk("VEVENT")}
    for rec in records.rows():
        desc = by_uid[pass_uid(rec)]
        assert ("already up at the window start" in desc) == (not rec["aos_known"])
        assert ("still up at the window end" in desc) == (not rec["los_known"])


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


def test_csv_numbers_are_the_values_repr_whatever_the_column_holds(records):
    """Rounded columns are formatted once per distinct value; a value that is not what the
    rounding gives (-0.0, NaN, an unrounded number) still comes out as repr shows it."""
    odd = records.take(np.arange(4))
    odd.columns["max_el_deg"] = np.array([-0.0, float("nan"), 12.345678, 1e-7])
    odd.columns["aos_az_deg"] = np.array([359.9, 0.0, 0.1, 180.0])
    rows = list(csv.reader(io.StringIO(to_csv(odd))))[1:]
    col = CSV_FIELDS.index
    assert [r[col("max_el_deg")] for r in rows] == ["-0.0", "nan", "12.345678", "1e-07"]
    assert [r[col("aos_az_deg")] for r in rows] == ["359.9", "0.0", "0.1", "180.0"]
    assert all(r[col("kind")] == "satellite" and r[col("priority")] == "" for r in rows)
    expected = [[str(x).lower() if isinstance(x, bool) else "" if x is None else
                 repr(x) if isinstance(x, float) else str(x) for x in
                 (row[k] for k in CSV_FIELDS)] for row in odd.rows()]
    assert rows == expected


def test_csv_of_awkward_names_is_what_the_csv_module_writes(table):
    # Non-ASCII, quoting and line breaks through the column-wise byte assembly; a name with
    # NUL (which that assembly uses as padding) through the cell-by-cell path, per part.
    awkward = ["Ωmega-1 «sat»", 'A,"B"', "line\nbreak", "tab\tname", ""]
    names = list(table.names)
    names[:len(awkward)] = awkward
    odd = type(table)(table.passes, names, table.stations, table.start, table.end)
    with_nul = type(table)(table.passes, ["NUL\0END"] * len(names), table.stations,
                           table.start, table.end)
    for t in (odd, with_nul):
        records = pass_records(t)
        assert to_csv(records) == _csv_module_text(records)
        # JSON likewise, column-wise, is json.dumps of each record's dict (NaN included).
        records.columns["tca_s"] = records["tca_s"].copy()
        records.columns["tca_s"][1] = float("nan")
        doc = to_json(records, {"a": 1})
        lines = [json.dumps(rec) for rec in records.rows()]
        assert doc.split('"passes": [\n  ')[1].split("\n ],")[0] == ",\n  ".join(lines)
        assert json.loads(doc.replace("NaN", "null"))["passes"][0]["target"] == \
            records["target"][0]
    assert any(t in to_csv(pass_records(odd)) for t in ('"A,""B"""', "Ωmega-1 «sat»"))


def test_categories_follow_take_and_a_replaced_column_is_written(records):
    part = records.take(np.arange(len(records))[::-2])
    column, codes, values = part.categories["target"]
    assert column is part["target"] and list(np.asarray(values, dtype=object)[codes]) == \
        list(part["target"])
    replaced = records.take(np.arange(3))
    replaced.columns["target"] = np.array(["X", "Y", "Z"], dtype=object)
    rows = list(csv.DictReader(io.StringIO(to_csv(replaced))))
    assert [r["target"] for r in rows] == ["X", "Y", "Z"]


def test_text_columns_with_quotes_or_commas_are_escaped_as_csv_and_json_do(records):
    odd = records.take(np.arange(3))
    odd.columns["aos"] = np.array(['say "hi"', "a,b", "back\\slash"])
    rows = list(csv.DictReader(io.StringIO(to_csv(odd))))
    assert [r["aos"] for r in rows] == ['say "hi"', "a,b", "back\\slash"]
    passes = json.loads(to_json(odd))["passes"]
    assert [p["aos"] for p in passes] == ['say "hi"', "a,b", "back\\slash"]


def test_values_python_calls_equal_are_written_each_as_it_is(records):
    # 1, 1.0 and True are equal in Python (and 0.0, -0.0), but each is written differently.
    part = records.take(np.arange(4))
    part.set("priority", [1, 1.0, True, 1])
    part.set("plan_max_error_deg", [0.0, -0.0, 0.0, -0.0])
    passes = json.loads(to_json(part))["passes"]
    want = [json.loads(json.dumps(r)) for r in part.rows()]
    assert [(p["priority"], type(p["priority"])) for p in passes] == \
        [(r["priority"], type(r["priority"])) for r in want]
    assert [str(p["plan_max_error_deg"]) for p in passes] == ["0.0", "-0.0", "0.0", "-0.0"]
    rows = list(csv.DictReader(io.StringIO(to_csv(part))))
    assert [r["priority"] for r in rows] == ["1", "1.0", "true", "1"]
    assert [r["plan_max_error_deg"] for r in rows] == ["0.0", "-0.0", "0.0", "-0.0"]


def test_a_category_column_cannot_be_edited_in_place(records):
    # Its cells are written from the category's codes: an edit in place would not show.
    part = records.take(np.arange(3))
    with pytest.raises(ValueError):
        part["target"][0] = "RENAMED"
    part.columns["target"] = np.array(["X", "Y", "Z"], dtype=object)
    assert [r["target"] for r in csv.DictReader(io.StringIO(to_csv(part)))] == ["X", "Y", "Z"]
