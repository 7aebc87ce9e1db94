"""Rotator specs, presets and the one motor model (AxisMotor / drive_axis)."""

import copy
import re
from pathlib import Path

import numpy as np
import pytest

from tracker.config import parse_config
from tracker.errors import ConfigError
from tracker.mount import (
    PRESETS,
    AxisMotor,
    MotorModel,
    MountFrame,
    RotatorSpec,
    bends_s,
    drive_axis,
    preset,
)


def test_presets_are_valid_and_have_published_rates():
    g = preset("g-5500")
    assert g.az_span_deg == 450 and g.stop_bearing_deg == 0 and g.el_max_deg == 180
    assert 360 / g.az_rate_deg_s == pytest.approx(58)
    assert 180 / g.el_rate_deg_s == pytest.approx(67)
    slow = preset("G-5500", mains_hz=50)
    assert 360 / slow.az_rate_deg_s == pytest.approx(58 * 6 / 5)
    dxa = preset("G-1000DXA")
    assert not dxa.has_elevation and dxa.az_span_deg == 450
    assert len(dxa.az_speed_rates_deg_s) == 4
    assert list(dxa.az_speed_rates_deg_s) == sorted(dxa.az_speed_rates_deg_s)
    assert preset("G-1000DXA", 50) == dxa  # DC drive: mains frequency does not matter
    assert preset("G-400").az_span_deg == 360 and not preset("G-400").has_elevation
    for name in ("G-5400B", "G-5600B", "G-800DXA", "G-2800DXA", "generic-k3ng"):
        assert name in PRESETS


@pytest.mark.parametrize("name, span, stop, el_max, n_speeds", [
    ("G-5500", 450, 0, 180, 0),
    # the GS-232B manual has the G-400 and G-5400B/G-5600B set to 360 deg mode (P36)
    ("G-5400B", 360, 180, 180, 0),
    ("G-5600B", 360, 180, 180, 0),
    ("G-800DXA", 450, 0, None, 4),
    ("G-1000DXA", 450, 0, None, 4),
    ("G-2800DXA", 450, 0, None, 4),
    ("G-400", 360, 180, None, 0),
    ("generic-k3ng", 360, 180, 90, 0),
])
def test_every_preset(name, span, stop, el_max, n_speeds):
    spec = preset(name)
    assert spec is PRESETS[name] and preset(name.lower()) == spec
    assert (spec.az_span_deg, spec.stop_bearing_deg, spec.el_max_deg) == (span, stop, el_max)
    assert spec.has_elevation == (el_max is not None)
    assert spec.has_elevation == (spec.el_rate_deg_s is not None)
    assert len(spec.az_speed_rates_deg_s) == n_speeds
    if n_speeds:  # X1 slowest .. X4 fastest; the default rate is the fastest step
        rates = spec.az_speed_rates_deg_s
        assert list(rates) == sorted(rates) and rates[-1] == pytest.approx(spec.az_rate_deg_s,
                                                                        rel=1e-3)
    slow = preset(name, 50)
    if name.startswith("G-") and "DXA" not in name:  # AC motors: 5/6 of the 60 Hz speed
        assert slow.az_rate_deg_s == pytest.approx(spec.az_rate_deg_s * 5 / 6)
        assert slow.name == f"{name}@50Hz"
        if spec.has_elevation:
            assert slow.el_rate_deg_s == pytest.approx(spec.el_rate_deg_s * 5 / 6)
    else:  # DC drives and the K3NG's own speed control do not care about mains
        assert slow == spec


def test_dxa_speed_steps_span_the_published_rotation_times():
    for name, fastest_s, slowest_s in (("G-800DXA", 43, 99), ("G-1000DXA", 40, 100),
                                       ("G-2800DXA", 50, 110)):
        rates = preset(name).az_speed_rates_deg_s
        assert 360 / rates[0] == pytest.approx(slowest_s, rel=1e-3)
        assert 360 / rates[-1] == pytest.approx(fastest_s, rel=1e-3)


def test_unknown_preset_and_mains():
    with pytest.raises(ConfigError, match="known presets"):
        preset("G-9999")
    with pytest.raises(ConfigError, match="mains_hz"):
        preset("G-5500", 55)


def rotator_from_config(name: str, table: dict) -> RotatorSpec:
    """A ``[rotator.NAME]`` section through the config file parser."""
    table = {k: list(v) if isinstance(v, tuple) else v for k, v in table.items()}
    return parse_config({"rotator": {name: table}}, Path("c.toml")).rotators[name]


@pytest.mark.parametrize("fields, key", [
    ({"az_span_deg": 500}, "az_span_deg"),
    ({"az_rate_deg_s": 0}, "az_rate_deg_s"),
    ({"el_rate_deg_s": -2}, "el_rate_deg_s"),
    ({"az_rate_deg_s": "fast"}, "az_rate_deg_s"),
    ({"el_max_deg": 190}, "el_max_deg"),
    ({"stop_bearing_deg": 360}, "stop_bearing_deg"),
    ({"park_az_deg": 400, "az_span_deg": 360}, "park_az_deg"),
    ({"az_speed_rates_deg_s": (1.0, 0.0)}, "az_speed_rates_deg_s[1]"),
    ({"az_speed_rates_deg_s": (1.0, "x")}, "az_speed_rates_deg_s[1]"),
    ({"start_delay_s": -1}, "start_delay_s"),
    ({"resolution_deg": 0}, "resolution_deg"),
])
def test_bad_specs_name_the_field(fields, key):
    with pytest.raises(ConfigError, match=re.escape(key)):
        RotatorSpec(name="bad", **fields)
    with pytest.raises(ConfigError, match=re.escape(key)):
        rotator_from_config("bad", dict(fields))


def test_rotator_from_config():
    spec = rotator_from_config("roof", {"preset": "G-5500", "mains_hz": 50,
                                        "el_max_deg": 170, "park_az_deg": 180})
    assert spec.name == "roof" and spec.el_max_deg == 170 and spec.park_az_deg == 180
    assert spec.az_rate_deg_s == pytest.approx(preset("G-5500", 50).az_rate_deg_s)
    az_only = rotator_from_config("mast", {"az_only": True, "az_span_deg": 360,
                                           "az_speed_rates_deg_s": [2, 4, 6, 8]})
    assert not az_only.has_elevation and az_only.az_speed_rates_deg_s == (2, 4, 6, 8)
    with pytest.raises(ConfigError, match="unknown key 'speed'"):
        rotator_from_config("x", {"speed": 3})


def test_frames_south_stop():
    spec = preset("G-5400B")
    assert spec.bearing_of(0) == 180 and spec.mech_of(0) == 180
    assert spec.frame.mech_candidates(200) == [20.0]
    assert preset("G-5500").frame.mech_candidates(30) == [30.0, 390.0]


def test_frame_readback_candidates():
    """A read-back names every mechanical position it can mean (folded 0-359 scales)."""
    frame = preset("G-5500").frame
    assert frame.mechs_of_wire(40.0) == [40.0, 400.0]
    assert frame.mechs_of_wire(400.0) == [40.0, 400.0]
    south = MountFrame(360.0, 180.0, wire_takes_bearing=True)
    assert south.mechs_of_wire(180.0) == [0.0, 360.0]
    assert south.mechs_of_wire(90.0) == [270.0]


def test_frame_nearest_mech_of_wire_follows_the_belief():
    frame = preset("G-5500").frame
    assert frame.nearest_mech_of_wire(40.0, 380.0) == 400.0
    assert frame.nearest_mech_of_wire(40.0, 10.0) == 40.0
    # No belief: the controller's own scale (a 450 deg controller reports 0-450) ...
    assert frame.nearest_mech_of_wire(400.0) == 400.0
    # ... and of a bearing, its lowest mechanical azimuth.
    south = MountFrame(450.0, 180.0, wire_takes_bearing=True)
    assert south.nearest_mech_of_wire(200.0) == 20.0
    assert south.nearest_mech_of_wire(200.0, 370.0) == 380.0


@pytest.mark.parametrize(("spec", "wire_top"), [
    (preset("G-5500"), 450.0),
    (preset("G-5400B"), 360.0),
    (preset("G-5500").with_(stop_bearing_deg=180.0, controller_maps_south=True), 360.0),
])
def test_frame_wire_round_trip(spec, wire_top):
    frame = spec.frame
    assert frame.wire_az_max_deg == wire_top
    m = np.arange(0.0, spec.az_span_deg + 1.0, 5.0)
    wire = frame.wire_of(m)
    assert isinstance(wire, np.ndarray) and (wire <= wire_top).all()
    assert isinstance(frame.wire_of(10.0), float)
    back = frame.mech_of_wire(wire)
    # Of a bearing the lowest mechanical azimuth comes back; the same bearing either way.
    assert np.allclose(frame.bearing_of(back), spec.bearing_of(m))
    for mi in m:
        assert frame.nearest_mech_of_wire(frame.wire_of(float(mi)), float(mi)) == \
            pytest.approx(mi)
    if not spec.controller_maps_south:
        assert np.array_equal(back, m)
        assert frame.wire_of(100.0) == 100.0
    else:
        assert frame.wire_of(0.0) == 180.0 and frame.mech_max_deg(360.0) == spec.az_span_deg


def test_axis_start_delay_rate_and_arrival():
    ax = AxisMotor(0, 450, rate_deg_s=5, start_delay_s=0.5, resolution_deg=1, position_deg=10)
    assert ax.command(20.4, 0.0) == 20  # quantised
    assert ax.position(0.5) == pytest.approx(10)  # still in its start delay
    assert ax.position(1.5) == pytest.approx(15)
    assert ax.arrival_s() == pytest.approx(2.5)
    assert ax.position(10) == pytest.approx(20)


def test_axis_reversal_costs_a_new_delay_same_direction_does_not():
    ax = AxisMotor(0, 450, 5, 0.5, 1, 100)
    ax.command(200, 0)
    ax.command(300, 2.0)  # same direction while running: no new delay
    assert ax.position(3.0) == pytest.approx(100 + 5 * 2.5)
    ax.command(0, 4.0)  # reversal: waits again
    p = ax.position(4.0)
    assert ax.position(4.4) == pytest.approx(p)
    assert ax.position(5.5) == pytest.approx(p - 5)


def test_axis_clamps_to_limits_and_quantises():
    ax = AxisMotor(0, 180, 2, 0, 1, 90)
    assert ax.command(500, 0) == 180
    assert ax.command(-20, 0) == 0
    fine = AxisMotor(0, 90, 2, 0, 0.5, 0)
    assert fine.command(10.26, 0) == 10.5


def test_set_rate_during_rotation_and_jam():
    ax = AxisMotor(0, 450, 2, 0, 1, 0)
    ax.command(100, 0)
    ax.set_rate(4, 5)  # X4 during rotation: takes effect now
    assert ax.position(5) == pytest.approx(10)
    assert ax.position(7) == pytest.approx(18)
    with pytest.raises(ValueError):
        ax.set_rate(0, 7)
    ax.jam(7)
    assert ax.position(100) == pytest.approx(18) and not ax.moving(100)
    ax.jam(100, jammed=False)
    ax.command(30, 100)
    assert ax.position(200) == pytest.approx(30)


def test_motor_model_az_only():
    mm = MotorModel(preset("G-400"), az_deg=10)
    assert mm.el is None
    mm.command(50, 30, 0)
    assert mm.position(100) == (pytest.approx(50), 0.0)


def test_drive_axis_closed_form_matches_stepping_exactly():
    rng = np.random.default_rng(7)
    for _ in range(60):
        n = int(rng.integers(3, 200))
        cmd_t = np.cumsum(rng.uniform(0.2, 3.0, n))
        cmd = np.clip(200 + np.cumsum(rng.normal(0, 2, n))
                      + rng.choice([0, 0, 0, 60], n) * rng.choice([-1, 1], n), 0, 450)
        t_eval = np.linspace(cmd_t[0] - 5, cmd_t[-1] + 100, 700)
        kw = dict(min_deg=0, max_deg=450, rate_deg_s=float(rng.uniform(1, 8)),
                  start_delay_s=float(rng.choice([0.0, 0.5, 1.0])), resolution_deg=1.0,
                  position_deg=200.0, t_s=cmd_t[0] - 10)
        a, b = AxisMotor(**kw), AxisMotor(**kw)
        slow, slow_starts = drive_axis(a, cmd_t, cmd, t_eval, closed_form=False)
        fast, starts = drive_axis(b, cmd_t, cmd, t_eval)
        np.testing.assert_allclose(fast, slow, atol=1e-9)
        # The same starts too: a move that ends a stepped stretch is counted once.
        assert 0 < slow_starts == starts <= n
        assert a.position(cmd_t[-1] + 500) == pytest.approx(b.position(cmd_t[-1] + 500))
        assert 0 < starts <= n


def test_drive_axis_on_a_moving_axis_steps_the_motor_model():
    # An axis already running keeps its relay closed: no new start delay and no new start
    # for a command in the same direction; the closed form (moves from rest) would not know.
    kw = dict(min_deg=0, max_deg=450, rate_deg_s=2.0, start_delay_s=1.0, position_deg=100.0)
    a, b = AxisMotor(**kw), AxisMotor(**kw)
    a.command(200.0, 0.0)
    b.command(200.0, 0.0)
    t_eval = np.arange(5.0, 40.0, 0.5)
    pos, starts = drive_axis(a, [5.0, 10.0], [150.0, 80.0], t_eval)
    ref, ref_starts = drive_axis(b, [5.0, 10.0], [150.0, 80.0], t_eval, closed_form=False)
    np.testing.assert_array_equal(pos, ref)
    assert (starts, ref_starts) == (1, 1)             # the reversal at 10 s only
    assert pos[t_eval == 9.5][0] == pytest.approx(100.0 + 2.0 * 8.5)  # no delay at 5 s


def test_drive_axis_counts_one_start_per_step_from_rest():
    ax = AxisMotor(0, 450, 6, 0.5, 1, 100)
    t = np.arange(10.0)
    _, starts = drive_axis(ax, t, 100 + t, t)  # 1 deg/s in 1 deg steps: 9 moves from rest
    assert starts == 9


def _bent(t, pos):
    """The sample times at which positions ``pos`` at ``t`` change slope."""
    slope = np.diff(pos) / np.diff(t)
    return t[1:-1][np.abs(np.diff(slope)) > 1e-9]


def test_bends_are_where_a_driven_axis_starts_and_stops():
    # From rest on 100: to 110 at t=1 (starts at 1.5, 10 deg at 4 deg/s: stops at 4.0), a
    # command to where it stands at t=6 (no move), back to 104 at t=8 (8.5 .. 10.0). The
    # positions the motor model gives bend there and nowhere else.
    ax = AxisMotor(0, 450, 4.0, 0.5, 1.0, 100.0, 0.0)
    cmd_t, cmd = [1.0, 6.0, 8.0], [110.0, 110.0, 104.0]
    bends = bends_s(ax, cmd_t, cmd)
    assert sorted(bends.tolist()) == pytest.approx([1.5, 4.0, 8.5, 10.0])
    t = np.arange(0.0, 12.0 + 1e-9, 0.125)
    pos, _starts = drive_axis(copy.copy(ax), cmd_t, cmd, t)
    np.testing.assert_allclose(_bent(t, pos), [1.5, 4.0, 8.5, 10.0])
    assert ax.position(5.0) == 100.0                  # not mutated
    assert bends_s(ax, [], []).size == 0


def test_bends_include_every_bend_of_moves_that_overlap():
    # From rest on 100 at 4 deg/s, 0.5 s start delay: to 140 at t=1 (turns from 1.5), on to
    # 150 at t=3 while running (no stop, no delay), then back to 90 at t=5 while still running
    # (stops at 5 on the reversal, turns from 5.5, 24 deg: arrives at 11.5). Every bend of the
    # motor model's positions is among the instants given.
    ax = AxisMotor(0, 450, 4.0, 0.5, 1.0, 100.0, 0.0)
    cmd_t, cmd = [1.0, 3.0, 5.0], [140.0, 150.0, 90.0]
    t = np.arange(0.0, 14.0 + 1e-9, 0.125)
    pos, _starts = drive_axis(copy.copy(ax), cmd_t, cmd, t)
    bent = _bent(t, pos)
    np.testing.assert_allclose(bent, [1.5, 5.0, 5.5, 11.5])
    bends = bends_s(ax, cmd_t, cmd)
    assert all(np.any(np.abs(bends - b) < 1e-9) for b in bent), bends
    assert ax.position(5.0) == 100.0                  # not mutated


def test_a_command_to_where_a_running_axis_is_stops_it_and_that_is_a_bend():
    # To 140 at t=1 (turns from 1.5 at 4 deg/s); at t=3 it is on 106, and a command to 106
    # stops it there.
    ax = AxisMotor(0, 450, 4.0, 0.5, 1.0, 100.0, 0.0)
    cmd_t, cmd = [1.0, 3.0], [140.0, 106.0]
    t = np.arange(0.0, 8.0 + 1e-9, 0.125)
    pos, _starts = drive_axis(copy.copy(ax), cmd_t, cmd, t)
    np.testing.assert_allclose(_bent(t, pos), [1.5, 3.0])
    bends = bends_s(ax, cmd_t, cmd)
    assert all(np.any(np.abs(bends - b) < 1e-9) for b in (1.5, 3.0)), bends


def test_before_its_first_command_a_driven_axis_makes_the_move_it_was_making():
    # Told at t=0 to go from 100 to 110: it turns from 0.5 and arrives at 3.0, at rest when
    # the first command of the drive (t=4) comes. Closed form and stepping agree on the
    # samples before it, and with no command at all the axis just finishes its move.
    ax = AxisMotor(0, 450, 4.0, 0.5, 1.0, 100.0, 0.0)
    ax.command(110.0, 0.0)
    t = np.arange(0.0, 8.0 + 1e-9, 0.25)
    closed, _ = drive_axis(copy.copy(ax), [4.0], [120.0], t)
    stepped, _ = drive_axis(copy.copy(ax), [4.0], [120.0], t, closed_form=False)
    np.testing.assert_array_equal(closed, stepped)
    assert closed[t == 2.0][0] == 106.0 and closed[t == 0.25][0] == 100.0
    np.testing.assert_allclose(_bent(t, closed), [0.5, 3.0, 4.5, 7.0])
    alone, starts = drive_axis(copy.copy(ax), [], [], t)
    np.testing.assert_array_equal(alone, ax.position(t))
    assert starts == 0
    bends = bends_s(ax, [4.0], [120.0])
    assert all(np.any(np.abs(bends - b) < 1e-9) for b in (0.5, 3.0, 4.5, 7.0)), bends


def test_top_command_is_one_step_short_of_a_bearing_taking_controllers_stop():
    from tracker.mount import MountFrame

    south = MountFrame(360.0, 180.0, wire_takes_bearing=True)
    assert south.top_command_deg(1.0) == 359.0          # 360 would be bearing 180: the CCW end
    assert south.wire_of(south.top_command_deg(1.0)) == 179.0
    assert MountFrame(360.0, 180.0).top_command_deg(1.0) == 360.0      # takes mechanical
    assert MountFrame(450.0, 0.0).top_command_deg(1.0) == 450.0


def test_axis_stamp_changes_with_every_change_of_its_segment():
    """TrackCore keeps a proof while the motors' stamps stay: every way an axis's segment
    changes renews the stamp; a copy shares it (and its segment) until either changes."""
    from tracker.mount import AxisMotor, drive_axis

    a = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, 100.0, 0.0)
    seen = {a.stamp}
    for change in (lambda: a.command(150.0, 1.0), lambda: a.stop(3.0),
                   lambda: a.set_rate(3.0, 4.0), lambda: a.jam(5.0),
                   lambda: a.jam(6.0, jammed=False), lambda: a.rest_at(90.0, 7.0),
                   lambda: drive_axis(a, [8.0, 9.0], [95.0, 120.0], [8.0, 9.0, 20.0])):
        segment = a.segment()
        change()
        assert a.stamp not in seen, segment
        seen.add(a.stamp)
    b = copy.copy(a)
    assert b.stamp == a.stamp and b.segment() == a.segment()
    b.command(10.0, 30.0)
    assert b.stamp != a.stamp
    asked = (a.position(40.0), a.moving(40.0), a.direction(40.0))   # asking changes nothing
    assert asked and a.stamp in seen


def test_axis_scalar_position_is_the_segment_formula_and_moving_takes_it():
    """The scalar position (asked several times a live-loop cycle) is the array path's and
    the segment's clamped travel, before the start delay, during the move and after arrival;
    moving() handed that position answers as moving() on its own."""
    rng = np.random.default_rng(5)
    for case in range(300):
        a = AxisMotor(0.0, 450.0, float(rng.uniform(1.0, 8.0)), float(rng.uniform(0.0, 2.0)),
                      1.0, float(rng.uniform(0.0, 450.0)), 10.0)
        if case % 5:
            a.command(float(rng.uniform(0.0, 450.0)), float(rng.uniform(10.0, 12.0)))
        if case % 11 == 0:
            a.jam(12.5)
        t0_s, p0, target, delay_s, rate, jammed = a.segment()
        ts = rng.uniform(t0_s - 2.0, t0_s + 200.0, 25)
        for t, from_array in zip(ts.tolist(), a.position(ts).tolist(), strict=True):
            run = min(max((t - t0_s - delay_s) * rate, 0.0), abs(target - p0))
            expected = p0 if jammed else p0 + float(np.copysign(run, target - p0))
            assert a.position(t) == from_array == expected
            assert a.moving(t, a.position(t)) is a.moving(t)
