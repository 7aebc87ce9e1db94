"""Step-table compiler: encoding, limits, semantics, interval choice, chaining, plan files."""

from __future__ import annotations

import re

import numpy as np
import pytest
from test_steptable_fixtures import STATION, high_pass, iss_passes, iss_track, low_pass

from tracker.errors import ConfigError, LimitError
from tracker.geometry import MountPath
from tracker.mount import MotorModel, drive_axis, preset
from tracker.station import HorizonMask, Station
from tracker.steptable import (
    PROFILES,
    compile_pass,
    compile_program,
    format_plan_file,
    read_plan_file,
    table_profile,
    tables_from_points,
    write_plan_file,
)

G5500 = preset("G-5500")
K3NG_SPEC = preset("generic-k3ng")
AZ_ONLY = G5500.with_(name="G-1000", el_max_deg=None, el_rate_deg_s=None)


def mid_pass(track, half_s: float = 90.0):
    mid = 0.5 * (track.t_s[0] + track.t_s[-1])
    return track.slice_time(mid - half_s, mid + half_s)


# Encoding and limits ---------------------------------------------------------------------


def test_w_and_m_lines_are_encoded_exactly_as_the_manual():
    w = tables_from_points("W", 5, [(10, 20), (11, 21), (360, 180)], PROFILES["gs232b"])
    assert w.lines() == ["W005 010 020 011 021 360 180"]
    assert w.encode() == b"W005 010 020 011 021 360 180\r"
    m = tables_from_points("M", 999, [0, 7, 450], PROFILES["gs232a"])
    assert m.encode() == b"M999 000 007 450\r"
    assert m.wire_time_s(9600) == pytest.approx(len(b"M999 000 007 450\r") * 10 / 9600)


def test_1900_pairs_accepted_1901_refused():
    prof = PROFILES["gs232b"]
    ok = tables_from_points("W", 1, [(i % 451, i % 181) for i in range(1900)], prof)
    line = ok.lines()[0]
    assert len(line) == 4 + 8 * 1900 and re.fullmatch(r"W001( \d{3} \d{3}){1900}", line)
    too_many = tables_from_points("W", 1, [(1, 1)] * 1901, prof)
    with pytest.raises(LimitError, match=r"1901 pairs .* at most 1900"):
        too_many.lines()
    assert len(tables_from_points("M", 1, [5] * 3800, prof).lines()[0]) == 4 + 4 * 3800
    with pytest.raises(LimitError, match="3801 angles"):
        tables_from_points("M", 1, [5] * 3801, prof).encode()


@pytest.mark.parametrize("bad", [
    dict(kind="W", interval_s=0, points=[(1, 1), (2, 2)]),
    dict(kind="W", interval_s=1000, points=[(1, 1), (2, 2)]),
    dict(kind="W", interval_s=5, points=[(451, 1), (2, 2)]),
    dict(kind="W", interval_s=5, points=[(1, 181), (2, 2)]),
    dict(kind="W", interval_s=5, points=[(-1, 0), (2, 2)]),
    dict(kind="W", interval_s=5, points=[(1, 1)]),
    dict(kind="M", interval_s=5, points=[1.5, 2]),
])
def test_out_of_range_tables_refused(bad):
    table = tables_from_points(bad["kind"], bad["interval_s"], bad["points"],
                               PROFILES["gs232b"])
    with pytest.raises(LimitError):
        table.encode()


def test_k3ng_w_azimuth_limited_to_360_and_lines_to_50_chars():
    prof = PROFILES["k3ng"]
    with pytest.raises(LimitError, match="000-360"):
        tables_from_points("W", 5, [(361, 0), (1, 1)], prof).lines()
    t = tables_from_points("W", 5, [(i, i) for i in range(20)], prof)
    lines = t.lines()
    assert len(lines) == 4 and all(len(x) <= 50 for x in lines)
    assert all(x.startswith("W005 ") for x in lines)
    with pytest.raises(LimitError, match="at most 20"):
        tables_from_points("W", 5, [(1, 1)] * 21, prof).lines()
    # M clears the list on K3NG, so an M table is one line: 11 angles in 50 characters.
    assert prof.max_points("M") == 11
    assert len(tables_from_points("M", 5, list(range(11)), prof).lines()[0]) <= 50


def test_unknown_protocol_has_no_tables():
    with pytest.raises(ConfigError, match="no timed step tables"):
        table_profile("rotorez")
    assert table_profile("GS232B-manual").name == "gs232b"


# Semantics, prediction ---------------------------------------------------------------------


def test_command_times_follow_the_manual_semantics():
    prog = compile_program(MountPath.from_track(mid_pass(low_pass()), G5500), G5500,
                           "gs232b", interval_s=7)
    (table,) = prog.tables
    times = table.command_times()
    assert times[0] == table.arrive_t_s < prog.pass_start_t_s  # pre-positioned before AOS
    assert times[1] == table.start_t_s                        # T: point 2 at once
    assert np.allclose(np.diff(times[1:]), 7.0)               # then every sss seconds
    assert table.end_t_s >= prog.pass_end_t_s                  # the last window covers LOS
    # K3NG steps every sss + 1 seconds.
    kp = compile_program(MountPath.from_track(mid_pass(low_pass()), K3NG_SPEC), K3NG_SPEC,
                         "k3ng", interval_s=7)
    assert kp.period_s == 8.0
    assert np.allclose(np.diff(kp.tables[0].command_times()[1:]), 8.0)


def test_prediction_drives_the_one_motor_model():
    path = MountPath.from_track(mid_pass(low_pass()), G5500)
    prog = compile_program(path, G5500, "gs232b", interval_s=3, start_az_deg=100.0,
                           start_el_deg=0.0)
    (table,) = prog.tables
    motor = MotorModel(G5500, 100.0, 0.0, t_s=table.arrive_t_s)
    ref, _starts = drive_axis(motor.az, table.command_times(), table.az_deg,
                              prog.prediction.t_s, closed_form=False)
    assert np.allclose(ref, prog.prediction.ant_az_deg)
    assert prog.prediction.motor_starts > 0


def test_points_minimise_error_better_than_plain_rounding():
    """The hold-window choice beats commanding the rounded position at each step time."""
    path = MountPath.from_track(mid_pass(iss_track(*sorted(iss_passes(30))[0][:2])), G5500)
    prog = compile_program(path, G5500, "gs232b", interval_s=10)
    (table,) = prog.tables
    t = table.command_times()
    naive_az = np.rint(np.interp(t, path.t_s, path.az_m_deg))
    naive_el = np.rint(np.interp(t, path.t_s, path.el_deg))
    from tracker.steptable import predict

    naive = predict(path, G5500, t, naive_az, naive_el)
    assert prog.prediction.max_error_deg < 0.75 * naive.max_error_deg


@pytest.mark.parametrize("spec,protocol", [(G5500, "gs232b"), (K3NG_SPEC, "k3ng"),
                                           (AZ_ONLY, "gs232a")])
def test_every_angle_within_the_profile_and_rotator_range(spec, protocol):
    prof = table_profile(protocol)
    for aos, los, _ in iss_passes(5.0)[:4]:
        path = MountPath.from_track(iss_track(aos, los), spec)
        prog = compile_program(path, spec, prof, interval_s=3)
        for table in prog.tables:
            az = np.asarray(table.az_deg)
            assert az.dtype.kind == "i"
            assert 0 <= az.min() and az.max() <= min(spec.az_span_deg, prof.az_max_deg(
                table.kind))
            if spec.has_elevation:
                assert table.kind == "W"
                assert spec.el_min_deg <= table.el_deg.min()
                assert table.el_deg.max() <= spec.el_max_deg
            else:
                assert table.kind == "M" and table.el_deg is None
            assert all(len(x) <= (prof.max_line_chars or 10**9) for x in table.lines())


def test_planner_flip_paths_and_horizon_mask_respected():
    # A mask that blocks the west below 8 deg: no point may go under it.
    mask = HorizonMask((0.0, 180.0, 200.0, 340.0), (0.0, 0.0, 8.0, 8.0))
    station = Station("masked", STATION.lat_deg, STATION.lon_deg, 10.0, 0.0, mask)
    track = high_pass()
    prog = compile_pass(track, G5500, station, "gs232b", interval_s=2)
    assert prog.meta["mode"] in ("flip", "keyhole", "normal", "overlap")
    (table,) = prog.tables
    bearing = np.asarray(G5500.bearing_of(table.az_deg))
    el = np.asarray(table.el_deg, dtype=float)
    flipped = el > 90
    phys_bearing = np.where(flipped, (bearing + 180.0) % 360.0, bearing)
    phys_el = np.where(flipped, 180.0 - el, el)
    assert np.all(phys_el >= np.floor(station.horizon_at(phys_bearing)))
    assert prog.prediction.max_error_deg < 6.0


# Interval choice and chaining --------------------------------------------------------------


def test_default_interval_is_the_smallest_that_fits_one_table():
    path = MountPath.from_track(low_pass(), G5500)
    prog = compile_program(path, G5500, "gs232b")
    assert prog.interval_s == 1 and len(prog.tables) == 1
    kp = compile_program(MountPath.from_track(low_pass(), K3NG_SPEC), K3NG_SPEC, "k3ng")
    assert len(kp.tables) == 1 and len(kp.tables[0]) <= 20
    shorter = compile_program(MountPath.from_track(low_pass(), K3NG_SPEC), K3NG_SPEC, "k3ng",
                              interval_s=kp.interval_s - 1)
    assert shorter.points > 20


def test_max_error_picks_the_largest_interval_within_the_bound():
    path = MountPath.from_track(mid_pass(low_pass(), 150), G5500)
    prog = compile_program(path, G5500, "gs232b", max_error_deg=2.0)
    assert prog.prediction.max_error_deg <= 2.0
    assert prog.interval_s > 1
    from tracker.steptable import _interval_candidates

    larger = [s for s in _interval_candidates(300.0, 0) if s > prog.interval_s]
    for sss in larger:
        other = compile_program(path, G5500, "gs232b", interval_s=sss)
        assert other.prediction.max_error_deg > 2.0
    with pytest.raises(LimitError, match=r"best is .* Raise max_error_deg or give interval_s"):
        compile_program(path, G5500, "gs232b", max_error_deg=0.1)


def test_long_pass_is_chained_at_the_boundaries():
    path = MountPath.from_track(low_pass(), K3NG_SPEC)
    prog = compile_program(path, K3NG_SPEC, "k3ng", interval_s=2)
    assert len(prog.tables) > 2 and all(2 <= len(t) <= 20 for t in prog.tables)
    for a, b in zip(prog.tables, prog.tables[1:], strict=False):
        # The next table lands when the previous one's last point ends; it is sent one
        # wire time earlier, and its T comes one period later.
        assert b.arrive_t_s == pytest.approx(a.end_t_s)
        assert b.upload_t_s == pytest.approx(b.arrive_t_s - b.wire_time_s(9600))
        assert b.start_t_s == pytest.approx(b.arrive_t_s + prog.period_s)
    assert len(prog.chain_gaps_s) == len(prog.tables) - 1
    assert all(0 < g < 0.5 for g in prog.chain_gaps_s)
    assert "chained tables" in prog.summary()


def test_bad_requests_are_refused_clearly():
    path = MountPath.from_track(mid_pass(low_pass()), G5500)
    with pytest.raises(ConfigError, match="1-999"):
        compile_program(path, G5500, "gs232b", interval_s=1000)
    with pytest.raises(ConfigError, match="either"):
        compile_program(path, G5500, "gs232b", interval_s=5, max_error_deg=2)


def test_remaining_from_resumes_at_the_point_due():
    prog = compile_program(MountPath.from_track(mid_pass(low_pass()), G5500), G5500,
                           "gs232b", interval_s=5)
    (table,) = prog.tables
    now = table.start_t_s + 12.0  # point index 3 (0-based) is due from T+10 to T+15
    rest = table.remaining_from(now, upload_s=1.0)
    assert rest.az_deg[0] == table.az_deg[3] and len(rest) == len(table) - 3
    assert rest.start_t_s == pytest.approx(table.start_t_s + 15.0)
    assert rest.end_t_s == pytest.approx(table.end_t_s)
    assert table.remaining_from(table.end_t_s + 1, 1.0) is None


# Plan files ------------------------------------------------------------------------------


def test_plan_file_round_trip(tmp_path):
    prog = compile_program(MountPath.from_track(low_pass(), K3NG_SPEC), K3NG_SPEC, "k3ng",
                           interval_s=4, meta={"target": "ISS (ZARYA)", "station": "JO22"})
    f = tmp_path / "pass.steps"
    write_plan_file(prog, f, {"element_epoch": "2026-08-22T12:00:46Z"})
    text = f.read_text()
    for key in ("# station: JO22", "# target: ISS (ZARYA)", "# element_epoch: 2026-08-22",
                "# t_utc: 2026-08-", "# interval_s: 4 (steps every 5 s)",
                "# predicted_error_deg: max"):
        assert key in text
    back = read_plan_file(f)
    assert len(back.tables) == len(prog.tables)
    for a, b in zip(prog.tables, back.tables, strict=True):
        assert a.lines() == b.lines()
        assert abs(a.start_t_s - b.start_t_s) < 1e-3
        assert abs(a.upload_t_s - b.upload_t_s) < 1e-3
    assert format_plan_file(prog).count("\nT\n") == len(prog.tables)


def test_broken_plan_file_names_file_and_line(tmp_path):
    prog = compile_program(MountPath.from_track(mid_pass(low_pass()), G5500), G5500,
                           "gs232b", interval_s=10)
    f = tmp_path / "p.steps"
    write_plan_file(prog, f)
    lines = f.read_text().splitlines()
    i = next(k for k, x in enumerate(lines) if x.startswith("W"))
    lines[i] = lines[i].replace(" ", "  ", 1)
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(ConfigError, match=rf"p\.steps:{i + 1}: not a long-form"):
        read_plan_file(f)
    f.write_text("\n".join(x for x in lines if x != "T") + "\n")
    with pytest.raises(ConfigError):
        read_plan_file(f)
    with pytest.raises(ConfigError, match="cannot read"):
        read_plan_file(tmp_path / "missing.steps")


def test_tables_are_checked_against_the_rotator_and_the_mask_they_are_sent_to():
    # A plan file may come from another rotator or station: check it where it is used.
    from tracker.steptable import check_tables_fit

    mask = HorizonMask((0.0, 180.0, 200.0, 340.0), (0.0, 0.0, 8.5, 8.5))
    station = Station("masked", STATION.lat_deg, STATION.lon_deg, 10.0, 0.0, mask)
    for track in (high_pass(), low_pass()):
        prog = compile_pass(track, G5500, station, "gs232b", interval_s=2)
        check_tables_fit(prog.tables, G5500, station)        # its own: fits
    over = tables_from_points("W", 1, [(10, 5), (400, 20), (420, 30)], PROFILES["gs232b"])
    with pytest.raises(LimitError, match=r"point 2 \(400 020\) is beyond G-400's 360"):
        check_tables_fit([over], G5500.with_(name="G-400", az_span_deg=360.0), STATION)
    wall = Station("wall", STATION.lat_deg, STATION.lon_deg, 0.0, 0.0,
                   HorizonMask((0.0,), (12.0,)))
    low = tables_from_points("W", 1, [(10, 15), (11, 11), (12, 20)], PROFILES["gs232b"])
    with pytest.raises(LimitError, match=r"point 2 \(011 011\) is below the horizon mask"):
        check_tables_fit([low], G5500, wall, "x.steps")
    flip = tables_from_points("W", 1, [(10, 170), (11, 169)], PROFILES["gs232b"])
    with pytest.raises(LimitError, match=r"point 1 .* below the horizon mask"):
        check_tables_fit([flip], G5500, wall)               # 10 deg over the top, south
    with pytest.raises(LimitError, match="elevation range 0-90"):
        check_tables_fit([flip], G5500.with_(name="G-5400", el_max_deg=90.0), STATION)


def test_a_450_deg_rotator_on_k3ng_tables_is_planned_inside_their_360_deg():
    """K3NG tables take W azimuths up to 360. A north-crossing pass that a G-5500 follows in
    its overlap (mechanical 360-450) used to be planned there and clipped to 360 point by
    point (tens of degrees off); it is planned inside 0-360 instead (a flip here)."""
    from tracker.planner import plan_pass
    from tracker.testing import synthetic_pass

    track = synthetic_pass(30.0, 0.0, duration_s=600.0)      # culminates due north
    assert plan_pass(track, G5500, STATION, lead_s=0.0).mode == "overlap"
    prog = compile_pass(track, G5500, STATION, "k3ng", interval_s=2)
    assert prog.meta["mode"] != "overlap"
    assert max(az for table in prog.tables for az in table.az_deg) <= 360
    assert prog.prediction.max_error_deg < 3.0, prog.prediction.max_error_deg
