"""The clairvoyant lower bound on motor starts (tracker/startbound.py): never above a schedule
that keeps the band (hand counts, a brute force over command sequences through THE motor
model, the whole-pass schedule), above the per-axis relaxation where the axes share the
band, and not fooled by slow targets."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from _stream_fakes import T0, arc_pass

from tracker import compiled
from tracker.geometry import MountPath, pointing_error_deg
from tracker.mount import AxisMotor, MotorModel, drive_axis, preset
from tracker.schedule import plan_schedule
from tracker.startbound import branch_paths, start_lower_bound, start_lower_bound_any_branch

SPEC = preset("G-5500", 50)


def _bound(ts, az, el, band_deg, park):
    return start_lower_bound(SPEC, ts, np.asarray(az, float), np.asarray(el, float),
                             np.asarray(az, float), np.asarray(el, float), band_deg, park=park)


def _key(axis: AxisMotor, t_s: float) -> tuple:
    if not axis.moving(t_s):
        return ("rest", round(float(axis.position(t_s)), 9))
    t0, p0, target, delay, _rate, _jam = axis.segment()
    return ("move", round(p0, 9), target, round(t0 + delay, 9))


def _command(axis: AxisMotor, target: float | None, t_s: float) -> tuple[AxisMotor, int]:
    if target is None:
        return axis, 0
    axis = copy.copy(axis)
    was = axis.direction(t_s)
    axis.command(target, t_s)
    return axis, int(axis.direction(t_s) not in (0, was))     # as drive_axis counts a start


def _brute_force(ts, az, el, band_deg, park, reach_deg=2, cycle_s=0.5):
    """Fewest starts over every command sequence on a ``cycle_s`` grid (each axis: nothing,
    or an integer target within ``reach_deg`` of where it is) that keeps the great-circle
    error within the band at every sample; motor states that behave alike are merged."""
    t = float(ts[0])
    m = MotorModel(SPEC, park[0], park[1], t)
    states = {None: (0, m.az, m.el)}
    while t <= ts[-1] + 1e-9:
        due = [k for k in range(len(ts)) if t - 1e-9 <= ts[k] < t + cycle_s - 1e-9]
        new: dict = {}
        for starts, a, e in states.values():
            opts = [[None, *(float(q) for q in range(round(float(x.position(t))) - reach_deg,
                                                     round(float(x.position(t))) + reach_deg + 1))]
                    for x in (a, e)]
            for qa in opts[0]:
                a2, sa = _command(a, qa, t)
                for qe in opts[1]:
                    e2, se = _command(e, qe, t)
                    if any(pointing_error_deg(SPEC, float(a2.position(float(ts[k]))),
                                              float(e2.position(float(ts[k]))),
                                              (float(az[k]), float(el[k]))) > band_deg
                           for k in due):
                        continue
                    key = (_key(a2, t + cycle_s), _key(e2, t + cycle_s))
                    if key not in new or new[key][0] > starts + sa + se:
                        new[key] = (starts + sa + se, a2, e2)
        states = new
        if not states:
            return None
        t += cycle_s
    return min(s for s, _a, _e in states.values())


def test_a_still_target_needs_one_start_per_axis_away_from_park():
    ts = np.arange(0.0, 30.0, 0.25)
    az, el = np.full_like(ts, 40.3), np.full_like(ts, 20.6)
    assert _bound(ts, az, el, 2.0, (0.0, 0.0)) == 2
    assert _bound(ts, az, el, 2.0, (40.0, 0.0)) == 1
    assert _bound(ts, az, el, 2.0, (41.0, 21.0)) == 0


def test_never_above_the_brute_force_optimum_over_command_sequences():
    ts = np.arange(0.0, 4.0 + 1e-9, 0.25)
    for az, el, band in ((20.0 + 1.5 * ts, 10.0 + 0.0 * ts, 1.0),
                         (20.0 + 1.2 * ts, 10.0 + 0.8 * ts, 1.0)):
        best = _brute_force(ts, az, el, band, (20.0, 10.0))
        bound = _bound(ts, az, el, band, (20.0, 10.0))
        assert best is not None and bound is not None
        assert 1 <= bound <= best


def test_the_axes_share_the_band_so_the_bound_beats_each_axis_alone():
    ts = np.arange(0.0, 120.0 + 1e-9, 0.25)
    az, el = 100.0 + 0.5 * ts, 10.0 + 0.25 * ts
    still_az, still_el = np.full_like(ts, 100.0), np.full_like(ts, 10.0)
    for band in (1.5, 2.0):
        joint = _bound(ts, az, el, band, (100.0, 10.0))
        alone = (_bound(ts, az, still_el, band, (100.0, 10.0))      # elevation exact
                 + _bound(ts, still_az, el, band, (100.0, 10.0)))   # azimuth exact
        assert joint > alone


def test_a_slow_target_is_not_followed_with_one_start():
    # 0.1 deg/s for 120 s within 0.5 deg: the motor turns at 5 deg/s or not at all, so a hold
    # covers at most 2 x 0.5 deg of the target's 12 deg, 2 x (0.5 + 0.15) with the cells'
    # slack (module doc, item 4): at least 9 holds, 8 starts after the first. A bound that
    # let the motor crawl would say 1.
    ts = np.arange(0.0, 120.0 + 1e-9, 0.25)
    bound = _bound(ts, 50.0 + 0.1 * ts, np.full_like(ts, 5.0), 0.5, (50.0, 5.0))
    assert bound is not None and bound >= 8


def test_a_target_faster_than_the_motor_cannot_be_kept():
    ts = np.arange(0.0, 20.0, 0.25)
    assert _bound(ts, 50.0 + 8.0 * ts, np.full_like(ts, 5.0), 1.0, (50.0, 5.0)) is None


def test_never_above_the_whole_pass_schedule():
    track = arc_pass(duration_s=300, max_el_deg=30.0, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    az0, el0 = (round(float(x)) for x in path.mount_at(T0))
    motor = MotorModel(SPEC, az0, el0, T0)
    sch = plan_schedule(path, motor.az, motor.el, T0, T0 + 300.0, 2.5)
    assert sch is not None
    ts = np.arange(T0, T0 + 300.0 + 1e-9, 0.25)
    _az, n_az = drive_axis(copy.copy(motor.az), sch.t_s, sch.az_m_deg, ts)
    _el, n_el = drive_axis(copy.copy(motor.el), sch.t_s, sch.el_deg, ts)
    bearing, el = track.direction_at(ts)
    p_az, p_el = path.mount_at(ts)
    bound = start_lower_bound(SPEC, ts, bearing, el, p_az, p_el, 2.5, park=(az0, el0))
    assert bound is not None and 0.6 * (n_az + n_el) <= bound <= n_az + n_el


def test_the_compiled_bound_is_the_numpy_bound():
    """The programme's two implementations (numpy, and loops numba compiles) give the same
    bound, and the same None, on one branch and on every branch."""
    pytest.importorskip("numba")
    track = arc_pass(duration_s=300, max_el_deg=70.0, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    ts = np.arange(T0, T0 + 300.0 + 1e-9, 0.25)
    bearing, el = track.direction_at(ts)
    p_az, p_el = path.mount_at(ts)
    slow = np.arange(0.0, 20.0, 0.25)
    over_ts, over_bearing, over_el = _overhead()

    def bounds():
        return ([start_lower_bound(SPEC, ts, bearing, el, p_az, p_el, band, park=(0.0, 0.0),
                                   stride=stride)
                 for band in (1.0, 2.5, 5.0) for stride in (1, 3)]
                + [start_lower_bound(SPEC, over_ts, over_bearing, over_el,
                                     np.full_like(over_ts, 30.0), over_el, 2.0,
                                     park=(30.0, 84.0)),
                   start_lower_bound_any_branch(SPEC, over_ts, over_bearing, over_el, 2.0,
                                                park=(30.0, 84.0)),
                   start_lower_bound_any_branch(SPEC, slow, 50.0 + 8.0 * slow,
                                                np.full_like(slow, 5.0), 1.0,
                                                park=(50.0, 5.0))])

    got = {}
    for name in ("numpy", "numba"):
        previous = compiled.use(name)
        try:
            got[name] = bounds()
        finally:
            compiled.use(previous)
    assert got["numba"] == got["numpy"]
    assert got["numpy"][6] is None and got["numpy"][8] is None
    assert all(isinstance(b, int) and b > 0 for b in got["numpy"][:6])


# Every branch ------------------------------------------------------------------------------


def _overhead(band_deg: float = 2.0):
    """A target rising straight through the zenith at 1 deg/s (el 84 -> 90 -> 84): azimuth 30
    before, 210 after."""
    ts = np.arange(0.0, 12.0 + 1e-9, 0.25)
    el = 90.0 - np.abs(ts - 6.0)
    bearing = np.where(ts <= 6.0, 30.0, 210.0)
    return ts, bearing, el


def test_over_the_top_is_found_where_the_upright_branch_cannot_keep_the_band():
    ts, bearing, el = _overhead()
    park = (30.0, 84.0)
    # Upright, the azimuth must swing 180 deg within seconds of the zenith: no schedule.
    assert start_lower_bound(SPEC, ts, bearing, el, np.full_like(ts, 30.0), el, 2.0,
                             park=park) is None
    found = start_lower_bound_any_branch(SPEC, ts, bearing, el, 2.0, park=park)
    assert found is not None
    starts, branch = found
    # The elevation goes on up through 90 (in holds: the motor turns at its rate or not at
    # all), the azimuth stays.
    assert starts >= 1
    assert branch == "upright, mech az 30 then over the top, mech az 30"


def test_no_branch_keeps_a_target_faster_than_the_motor():
    ts = np.arange(0.0, 20.0, 0.25)
    assert start_lower_bound_any_branch(SPEC, ts, 50.0 + 8.0 * ts, np.full_like(ts, 5.0),
                                        1.0, park=(50.0, 5.0)) is None


def test_every_branch_is_never_above_the_brute_force_optimum():
    ts = np.arange(0.0, 4.0 + 1e-9, 0.25)
    az, el = 20.0 + 1.2 * ts, 10.0 + 0.8 * ts
    best = _brute_force(ts, az, el, 1.0, (20.0, 10.0))
    found = start_lower_bound_any_branch(SPEC, ts, az, el, 1.0, park=(20.0, 10.0))
    assert best is not None and found is not None
    assert 1 <= found[0] <= best


def test_every_branch_is_never_above_one_branch():
    track = arc_pass(duration_s=120, max_el_deg=30.0, pad_s=10)
    path = MountPath.from_track(track, SPEC)
    ts = np.arange(T0, T0 + 120.0 + 1e-9, 0.25)
    bearing, el = track.direction_at(ts)
    p_az, p_el = path.mount_at(ts)
    park = (round(float(p_az[0])), round(float(p_el[0])))
    one = start_lower_bound(SPEC, ts, bearing, el, p_az, p_el, 2.0, park=park)
    found = start_lower_bound_any_branch(SPEC, ts, bearing, el, 2.0, park=park)
    assert one is not None and found is not None
    assert found[0] <= one


def test_far_from_the_zenith_a_schedule_keeps_one_side_and_turn():
    ts, bearing, el = _overhead()
    low = el - 44.0
    kept = branch_paths(SPEC, bearing, low, may_cross=False)
    names = [name for name, _az, _el in kept]
    assert names and all(" then " not in n for n in names)
    # Either side, on each turn that comes within 180 deg of the 450 deg span.
    assert set(names) == {"upright, mech az 30..210", "upright, mech az 390..570",
                          "over the top, mech az -150..30", "over the top, mech az 210..390"}
    crossing = [n for n, _a, _e in branch_paths(SPEC, bearing, el)]
    assert "upright, mech az 30 then over the top, mech az 30" in crossing
    for _name, az, e in kept:
        assert len(az) == len(ts) == len(e)


def test_every_branch_keeps_a_turn_whose_target_lies_just_beyond_the_stop():
    # A 360 deg rotator parked at its clockwise stop (mech 360, bearing 0): a target at
    # bearing 2 is mech 2 on turn 0 and mech 362 on turn 1, beyond the stop, yet the antenna
    # resting at the stop keeps it within the band with no start at all.
    spec = SPEC.with_(az_span_deg=360.0, park_az_deg=360.0, park_el_deg=12.0)
    ts = np.arange(0.0, 12.0 + 1e-9, 0.25)
    el = 13.0 - np.abs(ts - 6.0) / 2.0
    found = start_lower_bound_any_branch(spec, ts, np.full_like(ts, 2.0), el, 5.0,
                                         park=(360.0, 12.0))
    assert found is not None and found[0] == 0


def test_every_branch_refuses_samples_an_azimuth_turn_apart():
    ts = np.arange(0.0, 400.0, 40.0)      # 40 s: over 180 deg of azimuth travel
    with pytest.raises(ValueError, match="stride"):
        start_lower_bound_any_branch(SPEC, ts, np.full_like(ts, 30.0), np.full_like(ts, 20.0),
                                     5.0)
