"""The live loop's per-cycle scalar paths agree with the array functions they stand in for
(random inputs; the reference is the array expression the loop used before)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from tracker.aim import _predict, _predict_all, needs_command, quiet_until_s
from tracker.geometry import (
    MountPath,
    pointing_enu,
    pointing_error_deg,
    pointing_error_rows_deg,
)
from tracker.mount import AxisMotor, MotorModel, preset
from tracker.skytrack import (
    SkyTrack,
    angle_between_deg,
    angle_between_scalar_deg,
    azel_to_enu,
    azel_to_enu_scalar,
    interp1,
    interp1_rows,
)
from tracker.stall import moving_axis, restart_axis

SPEC = preset("G-5500", 50)
AZ_ONLY = preset("G-400")
TOL = 1e-9


def test_interp1_is_np_interp_on_random_points_and_the_edges():
    rng = np.random.default_rng(7)
    xp = np.cumsum(rng.uniform(0.05, 3.0, 80))
    fp = rng.normal(size=80)
    xs = np.concatenate([rng.uniform(xp[0] - 5, xp[-1] + 5, 3000), xp])
    got = [interp1(float(x), xp.tolist(), fp.tolist()) for x in xs]
    assert got == [float(np.interp(float(x), xp, fp)) for x in xs]
    rows = np.stack([fp, fp[::-1] * 3.0, np.cos(fp)], axis=1)
    got_rows = np.array([interp1_rows(float(x), xp.tolist(), rows.tolist()) for x in xs])
    ref_rows = np.stack([np.interp(xs, xp, rows[:, k]) for k in range(3)], axis=1)
    assert np.array_equal(got_rows, ref_rows)


def test_scalar_unit_vectors_and_angles_agree_with_the_array_ones():
    rng = np.random.default_rng(8)
    az = rng.uniform(-30, 400, (2, 2000))
    el = rng.uniform(-10, 180, (2, 2000))
    a, b = azel_to_enu(az[0], el[0]), azel_to_enu(az[1], el[1])
    sa = [azel_to_enu_scalar(float(x), float(y)) for x, y in zip(az[0], el[0], strict=True)]
    assert np.max(np.abs(np.array(sa) - a)) <= TOL
    got = np.array([angle_between_scalar_deg(u, v) for u, v in zip(a.tolist(), b.tolist(),
                                                                    strict=True)])
    assert np.max(np.abs(got - angle_between_deg(a, b))) <= TOL


@pytest.mark.parametrize("spec", [SPEC, AZ_ONLY, SPEC.with_(stop_bearing_deg=180.0)])
def test_pointing_error_float_path_agrees_with_the_array_path(spec):
    rng = np.random.default_rng(9)
    n = 1500
    ant_az = rng.uniform(0, spec.az_span_deg, n)
    ant_el = rng.uniform(0, 180, n)
    t_az, t_el = rng.uniform(0, 360, n), rng.uniform(-5, 90, n)
    ref = pointing_error_deg(spec, ant_az, ant_el, (t_az, t_el))
    got = [pointing_error_deg(spec, float(a), float(e), (float(x), float(y)))
           for a, e, x, y in zip(ant_az, ant_el, t_az, t_el, strict=True)]
    assert all(isinstance(g, float) for g in got)
    assert np.max(np.abs(np.array(got) - ref)) <= TOL
    ref_no_el = pointing_error_deg(spec, ant_az, None, (t_az, t_el))
    got_no_el = [pointing_error_deg(spec, float(a), None, (float(x), float(y)))
                 for a, x, y in zip(ant_az, t_az, t_el, strict=True)]
    assert np.max(np.abs(np.array(got_no_el) - ref_no_el)) <= TOL


@pytest.mark.parametrize("stop_deg", [0.0, 180.0])
@pytest.mark.parametrize("low_deg", [0.5, -30.0, 0.0])
def test_pointing_error_rows_is_the_pairs_error(stop_deg, low_deg):
    # (az rows from low_deg: all above 0 takes np.fmod for np.mod, else np.mod itself)
    rng = np.random.default_rng(18)
    az = rng.uniform(low_deg, 450.0, (7, 40))
    az[:, :3] = low_deg
    el = rng.uniform(0.0, 180.0, (5, 40))
    i_az, i_el = rng.integers(0, 7, 23), rng.integers(0, 5, 23)
    target = azel_to_enu(rng.uniform(0, 360, 40), rng.uniform(-5, 90, 40))
    ref = angle_between_deg(pointing_enu(az[i_az], el[i_el], stop_deg), target)
    got = pointing_error_rows_deg(az, el, i_az, i_el, stop_deg, target)
    assert np.array_equal(got, ref)


def test_bearing_of_float_path_is_np_mod():
    frame = SPEC.with_(stop_bearing_deg=180.0).frame
    ms = np.random.default_rng(10).uniform(-500, 900, 2000)
    assert [frame.bearing_of(float(m)) for m in ms] == frame.bearing_of(ms).tolist()


def _paths():
    rng = np.random.default_rng(11)
    t = np.arange(1000.0, 1600.0, 1.0)
    az = np.cumsum(rng.uniform(0.0, 1.5, len(t))) + 20.0
    el = 80.0 * np.sin(np.pi * (t - t[0]) / (t[-1] - t[0]))
    own = MountPath.from_arrays(t, az, el, SPEC)
    sky = azel_to_enu(np.mod(az + rng.normal(0, 2, len(t)), 360.0), el + rng.normal(0, 2,
                                                                                    len(t)))
    with_target = MountPath(t, az, el, 0.0, sky)
    return [own, with_target]


@pytest.mark.parametrize("path", _paths())
def test_path_error_float_path_agrees_with_the_array_expression(path):
    rng = np.random.default_rng(12)
    ts = rng.uniform(path.start_s - 20, path.end_s + 20, 2000)
    az = rng.uniform(0, 450, len(ts))
    el = rng.uniform(0, 180, len(ts))
    ref = angle_between_deg(pointing_enu(az, el, path.stop_bearing_deg), path.target_enu(ts))
    got = [path.error_deg(float(t), float(a), float(e)) for t, a, e in zip(ts, az, el,
                                                                            strict=True)]
    assert np.max(np.abs(np.array(got) - ref)) <= TOL
    assert np.array_equal(path.error_deg(ts, az, el), ref)


def test_sky_track_direction_float_path_agrees_with_the_array_path():
    rng = np.random.default_rng(13)
    t = np.arange(0.0, 800.0, 1.0)
    track = SkyTrack.from_azel(t, np.mod(np.cumsum(rng.uniform(0, 2, len(t))), 360.0),
                               60.0 * np.sin(np.pi * t / 800.0))
    ts = rng.uniform(-10, 810, 1500)
    ref_az, ref_el = track.direction_at(ts)
    got = np.array([track.direction_at(float(x)) for x in ts])
    d_az = np.abs(np.mod(got[:, 0] - ref_az + 180.0, 360.0) - 180.0)
    assert d_az.max() <= TOL and np.max(np.abs(got[:, 1] - ref_el)) <= TOL


def _old_needs_command(path, az_axis, el_axis, t0_s, deadband_deg, lookahead_s, step_s=0.25):
    ts = t0_s + np.arange(0.0, max(lookahead_s, step_s) + 1e-9, step_s)
    ts = ts[ts <= path.end_s]
    if len(ts) == 0:
        return False
    az = az_axis.position(ts)
    el = el_axis.position(ts) if el_axis is not None else np.zeros_like(ts)
    err = angle_between_deg(pointing_enu(az, el, path.stop_bearing_deg), path.target_enu(ts))
    return bool(np.max(err) > deadband_deg)


def _motor_near(rng, path, off_deg: float, command_deg: float) -> tuple[float, MotorModel]:
    """A random time ``t0`` on ``path`` and a motor resting about ``off_deg`` off the path
    there, half the time on its way to a target about ``command_deg`` off, commanded up to
    2 s before ``t0``."""
    t0 = float(rng.uniform(path.start_s, path.end_s + 2.0))
    az0, el0 = path.mount_at(t0)
    motor = MotorModel(SPEC, float(az0 + rng.normal(0, off_deg)),
                       float(np.clip(el0 + rng.normal(0, off_deg), 0, 180)), t0 - 2.0)
    if rng.random() < 0.5:
        motor.command(float(az0 + rng.normal(0, command_deg)),
                      float(np.clip(el0 + rng.normal(0, command_deg), 0, 180)),
                      t0 - rng.uniform(0, 2))
    return t0, motor


@pytest.mark.parametrize("path", _paths())
def test_needs_command_decides_as_the_array_version(path):
    rng = np.random.default_rng(14)
    decided = []
    for _ in range(1500):
        t0, motor = _motor_near(rng, path, off_deg=3.0, command_deg=5.0)
        band = float(rng.uniform(1.0, 6.0))
        look = float(rng.uniform(0.0, 2.0))
        new = needs_command(path, motor.az, motor.el, t0, band, look)
        assert new == _old_needs_command(path, motor.az, motor.el, t0, band, look)
        decided.append(new)
    assert 0 < sum(decided) < len(decided)     # both answers were exercised


@pytest.mark.parametrize("path", _paths())
def test_quiet_until_keeps_its_promise(path):
    """Up to the time quiet_until_s gives, needs_command says no at every cycle (and at any
    deadband from the one asked up); where it gives None, needs_command alone decides."""
    rng = np.random.default_rng(16)
    spans = []
    for _ in range(300):
        t0, motor = _motor_near(rng, path, off_deg=2.0, command_deg=3.0)
        band = float(rng.uniform(1.0, 6.0))
        until = quiet_until_s(path, motor.az, motor.el, t0, band, 1.0)
        if until is None:
            continue
        assert until >= t0
        spans.append(until - t0)
        for t in np.arange(t0, until + 1e-9, 0.1):
            for level in (band, band + 1.0):
                assert not needs_command(path, motor.az, motor.el, float(t), level, 1.0)
    assert len(spans) >= 10 and max(spans) >= 1.0    # promises were made, beyond one cycle


def test_axis_at_rest_and_restarted_in_place_answer_as_before():
    rng = np.random.default_rng(17)
    for _ in range(500):
        a = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, float(rng.uniform(0, 450)), 0.0)
        if rng.random() < 0.6:
            a.command(float(rng.uniform(0, 450)), float(rng.uniform(0, 3)))
        t = float(rng.uniform(0, 120))
        # moving/position of an axis on its target take a shortcut: same answers
        assert a.moving(t) == (a.direction(t) != 0)
        pos, target = float(rng.uniform(0, 450)), float(rng.uniform(0, 450))
        moving = bool(rng.random() < 0.5)
        fresh = moving_axis(a, pos, target, t, moving)
        same = copy.copy(a)
        restart_axis(same, pos, target, t, moving)
        assert same.segment() == fresh.segment()
        for dt in (0.0, 0.3, 1.0, 40.0):
            assert same.position(t + dt) == fresh.position(t + dt)
            assert same.moving(t + dt) == fresh.moving(t + dt)


@pytest.mark.parametrize("moving", [False, True])
def test_predict_all_is_predict_per_target(moving):
    rng = np.random.default_rng(15)
    ts = np.arange(99.0, 160.0, 0.5)          # from before the command at 100
    for _ in range(60):
        axis = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, float(rng.uniform(0, 450)), 90.0)
        if moving:
            axis.command(float(rng.uniform(0, 450)), 99.5)
        # Some on the way (a running axis keeps its relay closed), some behind it, and where
        # it stands.
        targets = np.unique(np.concatenate([np.round(rng.uniform(0, 450, 12)),
                                            [round(axis.position(100.0))]]))
        before = copy.copy(axis.__dict__)
        positions, arr, starts = _predict_all(axis, targets, 100.0, ts)
        pos = positions(0, len(ts))
        assert np.array_equal(np.concatenate([positions(0, 7), positions(7, len(ts))], axis=1),
                              pos)
        assert axis.__dict__ == before
        for k, v in enumerate(targets):
            p, a, s = _predict(axis, float(v), 100.0, ts)
            assert np.array_equal(pos[k], p) and arr[k] == a and starts[k] == s


@pytest.mark.parametrize("path", _paths())
def test_target_travel_bound_holds(path):
    rng = np.random.default_rng(16)
    t0 = rng.uniform(path.start_s - 5, path.end_s + 5, 3000)
    t1 = t0 + rng.uniform(0.0, 4.0, len(t0))
    moved = angle_between_deg(path.target_enu(t0), path.target_enu(t1))
    bound = np.array([path.target_travel_bound_deg(float(a), float(b))
                      for a, b in zip(t0, t1, strict=True)])
    assert np.all(moved <= bound + 1e-9)


@pytest.mark.parametrize("path", _paths())
def test_choose_aim_by_error_blocks_is_choose_aim_on_all_samples(path, monkeypatch):
    import tracker.aim as aim

    rng = np.random.default_rng(17)
    states = []
    for _ in range(40):
        t0 = float(rng.uniform(path.start_s, path.end_s - 30.0))
        az0, el0 = path.mount_at(t0)
        motor = MotorModel(SPEC, float(az0 + rng.normal(0, 4)),
                           float(np.clip(el0 + rng.normal(0, 4), 0, 180)), t0 - 1.0)
        states.append((t0, motor, float(rng.uniform(1.5, 6.0))))

    def aims(block):
        monkeypatch.setattr(aim, "_ERROR_BLOCK", block)
        return [aim.choose_aim(path, m.az, m.el, t0, band) for t0, m, band in states]

    whole = aims(10**6)
    assert aims(1) == whole and aims(32) == whole
    assert max(a.hold_s for a in whole) > 32 * 0.5    # holds past the first block of 32


def _stations():
    from tracker.station import HorizonMask, Station

    mask = HorizonMask((0.0, 80.0, 170.0, 250.0, 330.0), (12.0, 3.5, 25.0, 0.0, 7.25))
    return [Station("flat", 48.0, 11.0, 0.0, min_el_deg=2.5),
            Station("masked", 48.0, 11.0, 0.0, min_el_deg=1.0, mask=mask)]


@pytest.mark.parametrize("station", _stations(), ids=lambda s: s.name)
@pytest.mark.parametrize("spec", [SPEC, SPEC.with_(stop_bearing_deg=180.0, az_span_deg=360.0)])
def test_raise_to_mask_float_path_agrees_with_the_array_path(spec, station):
    from tracker.geometry import raise_to_mask

    rng = np.random.default_rng(18)
    az = rng.uniform(0, spec.az_span_deg, 3000)
    el = np.round(rng.uniform(0, 180, 3000) * 2.0) / 2.0
    ref = raise_to_mask(spec, station, az, el)
    got = [raise_to_mask(spec, station, float(a), float(e)) for a, e in zip(az, el, strict=True)]
    assert all(isinstance(g, float) for g in got)
    assert np.array_equal(np.array(got), ref)
    assert np.any(ref != el)                        # some were raised (or lowered over the top)


@pytest.mark.parametrize("path", _paths())
def test_fixed_mount_within_s_bounds_every_error_until_the_time_it_gives(path):
    rng = np.random.default_rng(18)
    reached = []
    for _ in range(200):
        t0 = float(rng.uniform(path.start_s - 5.0, path.end_s + 5.0))
        az0, el0 = path.mount_at(min(max(t0, path.start_s), path.end_s))
        az, el = float(az0 + rng.normal(0, 2.0)), float(np.clip(el0 + rng.normal(0, 2.0),
                                                                0, 180))
        limit = float(rng.uniform(1.0, 6.0))
        stop = t0 + float(rng.uniform(5.0, 120.0))
        got = path.fixed_mount_within_s(az, el, t0, limit, stop)
        assert got >= t0
        assert path.fixed_mount_within_s(az, el, t0, limit, stop) == got   # kept errors
        if path.error_deg(t0, az, el) > limit:
            assert got == t0
        if got == t0:
            continue
        end = min(got, stop, path.end_s + 5.0)
        ts = np.arange(t0, end + 1e-9, 0.05)
        assert np.all(path.error_deg(ts, np.full(len(ts), az), np.full(len(ts), el))
                      <= limit + 1e-9)
        reached.append(end - t0)
    assert max(reached) >= 15.0       # spans far past what the error now alone shows


@pytest.mark.parametrize("path", _paths())
def test_quiet_until_at_rest_keeps_its_promise_far_ahead(path):
    rng = np.random.default_rng(19)
    spans = []
    for _ in range(150):
        t0 = float(rng.uniform(path.start_s, path.end_s))
        az0, el0 = path.mount_at(t0)
        motor = MotorModel(SPEC, float(az0 + rng.normal(0, 1.0)),
                           float(np.clip(el0 + rng.normal(0, 1.0), 0, 180)), t0 - 2.0)
        band = float(rng.uniform(2.0, 6.0))
        until = quiet_until_s(path, motor.az, motor.el, t0, band, 1.0)
        if until is None:
            continue
        spans.append(until - t0)
        for t in np.arange(t0, until + 1e-9, 0.25):
            assert not needs_command(path, motor.az, motor.el, float(t), band, 1.0)
    assert len(spans) >= 20 and max(spans) >= 10.0
