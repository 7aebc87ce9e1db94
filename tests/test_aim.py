"""The aim-point / deadband policy (pure numpy, THE motor model)."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.aim import choose_aim, gpredict_aim, needs_command, predicted_error
from tracker.geometry import MountPath
from tracker.mount import MotorModel, preset

SPEC = preset("G-5500", 50)


def arc_path(spec=SPEC, duration_s=600.0, az0=100.0, az1=260.0, max_el=60.0):
    t = np.arange(0.0, duration_s + 0.5, 1.0)
    f = t / duration_s
    return MountPath.from_arrays(t, az0 + (az1 - az0) * f, max_el * np.sin(np.pi * f), spec)


def follow(path, spec, deadband_deg, policy, cycle_s=0.5):
    """Drive the motor model through the pass with ``policy``; error sampled every 0.1 s."""
    az0, el0 = path.mount_at(path.start_s)
    motor = MotorModel(spec, float(az0), float(el0), path.start_s)
    cmds, errs = 0, []
    hold_until, level = -np.inf, deadband_deg
    t = path.start_s
    while t < path.end_s - cycle_s:
        lvl = deadband_deg if t >= hold_until else level
        if policy == "aim":
            if needs_command(path, motor.az, motor.el, t, lvl, cycle_s + 1.0):
                a = choose_aim(path, motor.az, motor.el, t, deadband_deg)
                motor.command(a.az_m_deg, a.el_deg, t)
                cmds += 1
                hold_until, level = t + a.hold_s, max(deadband_deg, a.peak_error_deg + 0.5)
        else:  # Gpredict: threshold on the current target, lead within the threshold
            az_now, el_now = path.mount_at(t)
            ant_az, ant_el = motor.position(t)
            if abs(az_now - ant_az) > deadband_deg or abs(el_now - ant_el) > deadband_deg:
                az, el = gpredict_aim(path, t, deadband_deg, cycle_s)
                motor.command(az, el, t)
                cmds += 1
        errs.extend(predicted_error(path, motor.az, motor.el, t, np.arange(t, t + cycle_s, 0.1)))
        t += cycle_s
    return cmds, np.array(errs)


def test_aim_leads_the_target_and_accounts_for_slew():
    path = arc_path()
    motor = MotorModel(SPEC, 100.0, 0.0, 0.0)
    aim = choose_aim(path, motor.az, motor.el, 0.0, 3.0)
    assert aim.aim_t_s > 0.0                      # ahead of the target, not on it
    assert aim.arrival_s > 0.0 + SPEC.start_delay_s
    assert aim.peak_error_deg <= 3.0 + 0.75       # deadband + quantisation
    assert aim.hold_s > 2 * SPEC.start_delay_s


def test_lagging_antenna_aims_where_the_target_will_be_on_arrival():
    path = arc_path()
    motor = MotorModel(SPEC, 100.0, 0.0, 0.0)     # 50 s late: target at ~113/15
    aim = choose_aim(path, motor.az, motor.el, 50.0, 3.0)
    target_at_arrival = path.mount_at(aim.arrival_s)
    assert aim.aim_t_s > aim.arrival_s - 1.0      # not where the target was when commanded
    assert abs(aim.az_m_deg - target_at_arrival[0]) < 6.0
    assert abs(aim.el_deg - target_at_arrival[1]) < 6.0


def test_needs_command_only_when_leaving_the_deadband():
    path = arc_path()
    motor = MotorModel(SPEC, 100.0, 0.0, 0.0)
    assert not needs_command(path, motor.az, motor.el, 0.0, 3.0, 0.5)
    assert needs_command(path, motor.az, motor.el, 30.0, 3.0, 0.5)


@pytest.mark.parametrize("deadband", [2.0, 3.0, 4.0])
def test_whole_pass_error_bounded_and_fewer_moves_than_gpredict_lead(deadband):
    path = arc_path()
    n_aim, e_aim = follow(path, SPEC, deadband, "aim")
    n_gp, e_gp = follow(path, SPEC, deadband, "gpredict")
    # Great-circle error stays within the deadband plus the 1 deg command quantisation.
    assert e_aim.max() <= deadband + 0.75
    assert n_aim <= n_gp
    # Gpredict's per-axis threshold allows a larger great-circle error.
    assert e_aim.max() < e_gp.max()


def test_azimuth_only_rotator():
    spec = preset("G-5500").with_(name="az-only", el_max_deg=None, el_rate_deg_s=None)
    t = np.arange(0.0, 301.0, 1.0)
    path = MountPath.from_arrays(t, 40.0 + 0.5 * t, None, spec)
    motor = MotorModel(spec, 40.0, None, 0.0)
    assert motor.el is None
    aim = choose_aim(path, motor.az, None, 20.0, 4.0)
    assert aim.el_deg is None
    assert 50.0 < aim.az_m_deg < 70.0


def test_over_the_top_pointing_counts_as_pointing():
    # A flipped mount (az + 180, 180 - el) points at the same sky: no error.
    path = MountPath.from_arrays([0.0, 10.0], [10.0, 10.0], [60.0, 60.0], SPEC)
    motor = MotorModel(SPEC, 190.0, 120.0, 0.0)
    err = predicted_error(path, motor.az, motor.el, 0.0, np.array([0.0, 5.0]))
    assert np.all(err < 1e-6)


def test_chosen_peak_stays_inside_the_deadband_when_the_antenna_keeps_up():
    # The sample where the error leaves the deadband belongs to the next command: counting
    # it made every candidate look 'lagging' and let peaks above the deadband through.
    path = arc_path()
    motor = MotorModel(SPEC, 100.0, 0.0, 0.0)
    peaks = []
    for t in np.arange(0.0, 590.0, 0.5):
        if needs_command(path, motor.az, motor.el, t, 2.8, 1.0):
            a = choose_aim(path, motor.az, motor.el, t, 2.8)
            motor.command(a.az_m_deg, a.el_deg, t)
            peaks.append(a.peak_error_deg)
    assert len(peaks) > 10 and max(peaks) <= 2.8


def test_approximate_path_is_scored_against_the_real_target():
    """A keyhole-style path that is 2 deg off the target: the aim policy's error is the
    error to the target, not to the path it follows."""
    from types import SimpleNamespace

    from tracker.skytrack import SkyTrack

    t = np.arange(0.0, 121.0, 1.0)
    track = SkyTrack.from_azel(t, 100.0 + 0.5 * t, np.full_like(t, 40.0), name="K")
    plan = SimpleNamespace(t_s=t, cmd_az_deg=100.0 + 0.5 * t, cmd_el_deg=np.full_like(t, 42.0),
                           lead_s=0.0, mode="keyhole", track=track,
                           visible=np.ones_like(t, dtype=bool))
    path = MountPath.exact_from_plan(plan, None, SPEC)
    motor = MotorModel(SPEC, 110.0, 42.0, 0.0)          # on the path at t = 20 s
    err = predicted_error(path, motor.az, motor.el, 20.0, np.array([20.0]))
    assert err[0] == pytest.approx(2.0, abs=0.05)
    assert np.allclose(path.mount_at(20.0), (110.0, 42.0))    # still follows the planned path


def test_near_the_zenith_an_azimuth_swing_goes_by_the_zenith():
    # A target 3 deg from the zenith (el 87, hardly moving: a high orbit near apogee) and the
    # antenna 2 deg from the zenith, 143 deg round in azimuth: 4.75 deg off. The path is in the
    # overlap (mechanical az 385), so reaching it the azimuth turns the long way, 217 deg:
    # at el 87-88 that sweeps the antenna round the zenith, 5 deg off when opposite, and so does
    # every point of the path. With the elevation at 90 while the azimuth turns, the error is
    # never more than it is now.
    t = np.arange(0.0, 601.0, 1.0)
    path = MountPath.from_arrays(t, 385.0 + 0.0005 * t, 87.0 - 0.0002 * t, SPEC)
    motor = MotorModel(SPEC, 168.0, 88.0, 0.0)
    err_now = float(predicted_error(path, motor.az, motor.el, 0.0, np.array([0.0]))[0])
    assert err_now == pytest.approx(4.75, abs=0.02)
    aim = choose_aim(path, motor.az, motor.el, 0.0, 4.8)
    assert aim.el_deg == 90.0
    motor.command(aim.az_m_deg, aim.el_deg, 0.0)
    ts = np.arange(0.0, aim.arrival_s + 5.0, 0.05)
    err = predicted_error(path, motor.az, motor.el, 0.0, ts)
    assert aim.peak_error_deg <= 4.8 and float(np.max(err)) <= 4.8
