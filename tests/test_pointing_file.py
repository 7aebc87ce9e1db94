"""Az/el schedule files: parsing, interpolation, errors with file:line, passes, planning."""

from __future__ import annotations

import re
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest
from _paths import DATA

from tracker.celestial import resolve
from tracker.errors import ConfigError, TrackerError
from tracker.event_labels import event_labels
from tracker.passes import find_passes
from tracker.pointing_file import ScheduleError, ScheduleTarget, parse_schedule
from tracker.station import Station

UTC = timezone.utc
SWEEP = DATA / "schedule_sweep.csv"
T18 = datetime(2026, 8, 22, 18, tzinfo=UTC).timestamp()
STATION = Station("home", 52.0, 5.0, 0.0)


def test_sweep_file_parses_header_comments_and_time_zones():
    target = ScheduleTarget.load(SWEEP)
    assert target.kind == "schedule" and target.name == "schedule_sweep"
    assert np.allclose(target.t_s, T18 + 600.0 * np.arange(6))
    assert np.allclose(target.az_deg, [300, 330, 350, 10, 30, 60])
    assert np.allclose(target.el_deg, [0, 10, 20, 20, 10, -2])
    assert not target.az_only


def test_interpolates_azimuth_the_short_way_and_nan_outside():
    target = ScheduleTarget.load(SWEEP)
    t = T18 + np.array([-1.0, 0.0, 300.0, 1500.0, 1650.0, 3000.0, 3001.0])
    track = target.observe(STATION, t)
    assert track.az_deg[1] == pytest.approx(300.0)
    assert track.az_deg[2] == pytest.approx(315.0) and track.el_deg[2] == pytest.approx(5.0)
    assert track.az_deg[3] == pytest.approx(0.0, abs=1e-9) or track.az_deg[3] == pytest.approx(
        360.0)
    assert track.az_deg[4] == pytest.approx(5.0)
    assert track.el_deg[5] == pytest.approx(-2.0)
    assert np.isnan(track.az_deg[[0, 6]]).all() and np.isnan(track.el_deg[[0, 6]]).all()
    assert np.isnan(track.range_km).all()


def test_round_trip_skytrack_to_csv_and_back(tmp_path):
    sun = resolve("sun")
    t = T18 - 6 * 3600 + np.arange(0.0, 3 * 3600.0, 300.0)
    original = sun.observe(STATION, t)
    lines = ["utc_time,az_deg,el_deg"]
    for ts, az, el in zip(original.t_s, original.az_deg, original.el_deg, strict=True):
        iso = datetime.fromtimestamp(ts, UTC).isoformat().replace("+00:00", "Z")
        lines.append(f"{iso},{az:.6f},{el:.6f}")
    path = tmp_path / "sun.csv"
    path.write_text("\n".join(lines) + "\n")
    loaded = resolve(str(path))
    assert isinstance(loaded, ScheduleTarget)
    back = loaded.observe(STATION, t)
    assert np.allclose(back.az_deg, original.az_deg, atol=1e-5)
    assert np.allclose(back.el_deg, original.el_deg, atol=1e-5)
    # Between the rows the schedule follows the Sun closely (linear interpolation, 5 min rows).
    mid = t[:-1] + 150.0
    truth = sun.observe(STATION, mid)
    interp = loaded.observe(STATION, mid)
    from tracker.skytrack import angular_separation_deg

    assert angular_separation_deg(interp.az_deg, interp.el_deg, truth.az_deg,
                                  truth.el_deg).max() < 0.05


def test_over_the_top_elevation_is_stored_as_the_sky_direction():
    _, az, el = parse_schedule("2026-08-22T18:00:00Z,10,100\n2026-08-22T18:01:00Z,20,80\n")
    assert az[0] == pytest.approx(190.0) and el[0] == pytest.approx(80.0)
    assert az[1] == pytest.approx(20.0) and el[1] == pytest.approx(80.0)


def test_azimuth_only_schedule_is_one_whole_pass(tmp_path):
    path = tmp_path / "az_only.csv"
    path.write_text("2026-08-22T18:00:00Z, 90\n2026-08-22T18:30:00Z, 120\n"
                    "2026-08-22T19:00:00Z, 180\n")
    target = resolve(f"schedule:{path}")
    assert target.az_only and np.all(target.el_deg == 0.0)
    passes = find_passes(target, STATION, T18 - 3600, T18 + 3 * 3600)
    assert len(passes) == 1
    assert passes[0].aos.timestamp() == pytest.approx(T18, abs=0.1)
    assert passes[0].los.timestamp() == pytest.approx(T18 + 3600, abs=0.1)
    assert event_labels(passes[0].kind) == ("start", "max el", "end")


def test_schedule_pass_is_where_el_is_above_the_horizon():
    target = ScheduleTarget.load(SWEEP)
    passes = find_passes(target, STATION, T18 - 3600, T18 + 3 * 3600)
    assert len(passes) == 1
    p = passes[0]
    assert p.aos.timestamp() == pytest.approx(T18, abs=0.1)  # el is exactly 0 at the first row
    # el goes 10 -> -2 between 18:40 and 18:50: crosses 0 at 18:40 + 10/12 * 600 s.
    assert p.los.timestamp() == pytest.approx(T18 + 2400 + 500, abs=0.1)
    assert p.max_el_deg == pytest.approx(20.0)
    assert T18 + 1200 - 1 <= p.tca.timestamp() <= T18 + 1800 + 1
    high = find_passes(target, STATION, T18 - 3600, T18 + 3 * 3600, min_el_deg=15.0)
    assert high[0].aos.timestamp() == pytest.approx(T18 + 900, abs=0.1)
    assert high[0].los.timestamp() == pytest.approx(T18 + 2100, abs=0.1)


def _write(tmp_path, text: str) -> Path:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return path


GOOD1 = "2026-08-22T18:00:00Z,100,10\n"


@pytest.mark.parametrize("text, line, message", [
    (GOOD1 + "2026-08-22T17:59:00Z,110,10\n", 2, "not after the previous point"),
    (GOOD1 + "2026-08-22T18:00:00Z,110,10\n", 2, "strictly increasing"),
    (GOOD1 + "2026-08-22T18:01:00Z,361,10\n", 2, "azimuth 361 is out of range"),
    (GOOD1 + "2026-08-22T18:01:00Z,-1,10\n", 2, "azimuth -1 is out of range"),
    (GOOD1 + "2026-08-22T18:01:00Z,100,181\n", 2, "elevation 181 is out of range"),
    (GOOD1 + "2026-08-22T18:01:00Z,100,-6\n", 2, "elevation -6 is out of range"),
    ("# c\n\n" + GOOD1 + "yesterday,100,10\n", 4, "cannot read time 'yesterday'"),
    (GOOD1 + "2026-08-22T18:01:00Z,east,10\n", 2, "must be numbers"),
    (GOOD1 + "2026-08-22T18:01:00Z,100,nan\n", 2, "finite"),
    (GOOD1 + "2026-08-22T18:01:00Z,100\n", 2, "give el_deg on every line or on none"),
    (GOOD1 + "2026-08-22T18:01:00Z;100;10\n", 2, "1 fields"),
    (GOOD1 + "2026-08-22T18:01:00Z,100,10,5\n", 2, "4 fields"),
])
def test_bad_lines_give_file_line_messages(tmp_path, text, line, message):
    path = _write(tmp_path, text)
    with pytest.raises(ScheduleError, match=re.escape(f"{path}:{line}: ") + ".*"
                       + re.escape(message)):
        ScheduleTarget.load(path)


def test_too_short_and_missing_files(tmp_path):
    path = _write(tmp_path, "utc_time,az_deg\n" + GOOD1)
    with pytest.raises(ScheduleError, match="at least two points"):
        ScheduleTarget.load(path)
    with pytest.raises(ScheduleError, match="cannot read schedule file"):
        resolve(f"schedule:{tmp_path / 'missing.csv'}")
    (tmp_path / "binary.csv").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ScheduleError, match="not a text file"):
        ScheduleTarget.load(tmp_path / "binary.csv")


def test_schedule_error_is_a_tracker_config_error():
    assert issubclass(ScheduleError, ConfigError) and issubclass(ScheduleError, TrackerError)


def test_header_only_allowed_first(tmp_path):
    path = _write(tmp_path, GOOD1 + "utc_time,az_deg,el_deg\n2026-08-22T18:01:00Z,100,10\n")
    with pytest.raises(ScheduleError, match=re.escape(f"{path}:2:")):
        ScheduleTarget.load(path)


def test_schedule_plans_into_a_mount_plan():
    planner = pytest.importorskip("tracker.planner")
    from tracker.mount import preset

    target = ScheduleTarget.load(SWEEP)
    p = find_passes(target, STATION, T18 - 3600, T18 + 3 * 3600)[0]
    track = p.track(step_s=10.0)
    spec = preset("G-5500")
    plan = planner.plan_pass(track, spec, STATION)
    # The sweep crosses north (300 -> 60 via 0): a 450° rotator with a north stop takes it
    # without an unwind, and follows the slow sweep closely.
    assert plan.mode in ("normal", "overlap")
    assert plan.lost_track_s == 0.0 and plan.max_error_deg < 2.0
    assert np.all((plan.cmd_az_deg >= 0) & (plan.cmd_az_deg <= spec.az_span_deg))
    assert np.nanmin(plan.cmd_el_deg) >= 0.0
    assert len(plan.t_s) == len(track)


def test_schedule_round_trips_into_a_step_table():
    """File -> target -> pass -> GS-232 W table lines -> parsed back: every point the
    controller will step to is the schedule's direction at that point's time (to the 1°
    wire resolution plus the slow sweep's motion within a hold window)."""
    steptable = pytest.importorskip("tracker.steptable")
    from tracker.mount import preset
    from tracker.protocols.gs232_tables import decode_table_line
    from tracker.skytrack import angular_separation_deg

    target = ScheduleTarget.load(SWEEP)
    p = find_passes(target, STATION, T18 - 3600, T18 + 3 * 3600)[0]
    program = steptable.compile_pass(p.track(step_s=5.0), preset("G-5500"),
                                     STATION, "gs232b", interval_s=10)
    points = []
    for line in program.lines():
        kind, interval, az, el = decode_table_line(line)
        if kind == "W":
            assert interval == 10 and el is not None
            points += list(zip(az, el, strict=True))
    t = np.concatenate([table.command_times() for table in program.tables])
    assert len(points) == len(t) == program.points > 250  # 48 min at 10 s, one table
    az = np.array([a for a, _ in points], dtype=float) % 360.0
    el = np.array([e for _, e in points], dtype=float)
    # Point 1 is the pre-position (before the schedule starts): the first row, 300/0.
    assert (az[0], el[0]) == (300.0, 0.0)
    want = target.observe(STATION, t[1:])
    sep = angular_separation_deg(az[1:], el[1:], want.az_deg, want.el_deg)
    assert np.all(np.isfinite(sep)) and sep.max() < 1.0
    # The table really follows the sweep across north (300 -> 0 -> ~58 deg).
    assert az[1:].max() > 350.0 and 50.0 < az[-1] < 65.0
