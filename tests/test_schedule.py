"""The whole-pass command schedule (tracker/schedule.py) and the live loop following it, on
virtual time: planned knowing the pass, checked through THE motor model, handed to the aim
policy when the read-back leaves it."""

from __future__ import annotations

import numpy as np
import pytest
from _stream_fakes import T0, arc_pass
from test_stream import Rig, track_errors

import tracker.stream as stream_mod
from tracker.geometry import MountPath
from tracker.mount import MotorModel, drive_axis, preset
from tracker.schedule import axis_schedule, plan_schedule
from tracker.stream import Phase, StreamSettings

SPEC = preset("G-5500", 50)
PLANNED = StreamSettings(deadband_deg=3.0, planned_schedule=True)


def _rest_on_path(path: MountPath, t_s: float) -> MotorModel:
    az, el = path.mount_at(t_s)
    return MotorModel(SPEC, round(float(az)), round(float(el)), t_s)


def test_axis_schedule_keeps_its_budget_with_one_start_per_command():
    t = np.arange(0.0, 300.0, 0.25)
    path = 10.0 + 0.4 * t                       # 0.4 deg/s, 120 deg in all
    cmds = axis_schedule(t, path, np.ones_like(t), 5.0, 0.5, 2.0, 10.0)
    assert cmds is not None and all(k % 2 == 0 for k, _q in cmds)   # on cycle instants
    axis = MotorModel(SPEC, 10.0, 0.0, 0.0).az
    pos, starts = drive_axis(axis, t[[k for k, _ in cmds]], [q for _, q in cmds], t)
    assert np.max(np.abs(pos - path)) <= 2.0 + 1e-9
    assert starts == len(cmds)
    # A sawtooth of +-2 deg over a 0.4 deg/s path: about one start per 4 deg of travel.
    assert 120.0 / 4.0 - 2 <= len(cmds) <= 120.0 / 4.0 + 3


def test_plan_schedule_keeps_the_great_circle_error_within_the_band():
    track = arc_pass(duration_s=600, max_el_deg=35.0, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    t0 = T0
    motor = _rest_on_path(path, t0)
    sch = plan_schedule(path, motor.az, motor.el, t0, T0 + 600.0, 2.8)
    assert sch is not None
    # The commands as the loop sends them, replayed through the motor model: the same
    # starts, the error against the target within the band at every sample.
    ts = np.arange(t0, T0 + 600.0 + 1e-9, 0.25)
    az, n_az = drive_axis(motor.az, sch.t_s, sch.az_m_deg, ts)
    el, n_el = drive_axis(motor.el, sch.t_s, sch.el_deg, ts)
    assert n_az + n_el == sch.starts
    assert float(np.max(path.error_deg(ts, az, el))) <= 2.8 + 1e-6
    assert sch.expected(float(ts[100])) == pytest.approx((az[100], el[100]))
    # Each axis alone within the whole band needs no more starts (the per-axis bound).
    p_az, p_el = path.mount_at(ts)
    alone = [axis_schedule(ts, p_az, np.abs(np.cos(np.radians(p_el))), SPEC.az_rate_deg_s,
                           0.5, 2.8, float(round(p_az[0]))),
             axis_schedule(ts, p_el, np.ones_like(ts), SPEC.el_rate, 0.5, 2.8,
                           float(round(p_el[0])))]
    assert sum(len(c) for c in alone) <= sch.starts


def test_plan_schedule_needs_both_axes_at_rest():
    track = arc_pass(duration_s=300, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    motor = _rest_on_path(path, T0)
    motor.command(200.0, 10.0, T0)
    assert plan_schedule(path, motor.az, motor.el, T0 + 1.0, T0 + 300.0, 2.8) is None


@pytest.fixture
def spies(monkeypatch):
    """Records every schedule planned and every aim the policy chooses (time, result)."""
    seen = {"schedules": [], "aims": []}
    plan, aim = stream_mod.plan_schedule, stream_mod.choose_aim

    def planned(*a, **k):
        sch = plan(*a, **k)
        seen["schedules"].append(sch)
        return sch

    def chosen(path, az, el, t_s, *a, **k):
        seen["aims"].append(t_s)
        return aim(path, az, el, t_s, *a, **k)

    monkeypatch.setattr(stream_mod, "plan_schedule", planned)
    monkeypatch.setattr(stream_mod, "choose_aim", chosen)
    return seen


def _sent(rig) -> list[tuple[float, float, float]]:
    """(t, az, el) of every command, from the cycles whose status counted one more."""
    out, count = [], 0
    for st in rig.status:
        if st.commands > count:
            out.append((st.t_s, st.command_az_m_deg, st.command_el_deg))
        count = st.commands
    return out


def test_the_live_loop_sends_the_planned_schedule_and_nothing_else(spies):
    rig = Rig(track=arc_pass(duration_s=400, max_el_deg=30.0, pad_s=30), settings=PLANNED)
    res = rig.run()
    assert res.completed and rig.core.phase is Phase.DONE
    (sch,) = spies["schedules"]
    assert sch is not None and sch.t_s[0] < rig.core.aos_s + 60.0
    # While the schedule runs the aim policy is never asked; every planned move went out
    # on its cycle, as planned.
    assert not [t for t in spies["aims"] if sch.t_s[0] - 1.0 <= t <= sch.end_s]
    during = [c for c in _sent(rig) if sch.t_s[0] - 1e-6 <= c[0] <= sch.end_s]
    assert [(az, el) for _t, az, el in during] == list(zip(sch.az_m_deg, sch.el_deg,
                                                            strict=True))
    assert all(abs(c[0] - t) <= 0.25 + 1e-6 for c, t in zip(during, sch.t_s, strict=True))
    assert track_errors(rig).max() <= 3.0 + 1.0      # deadband + integer read-back


def test_readback_off_the_schedule_hands_the_rest_of_the_pass_to_the_aim_policy(spies):
    def shove(rig):
        # Someone turns the antenna 6 deg in azimuth: not a contradiction (< 20 deg), but
        # no longer where the schedule put it.
        t = rig.clock.timestamp()
        az, el = rig.fake.model.position(t)
        rig.fake.model.command(az + 6.0, el, t)

    rig = Rig(track=arc_pass(duration_s=400, max_el_deg=30.0, pad_s=30), faults={150: shove},
              settings=PLANNED)
    res = rig.run()
    assert res.completed
    (sch,) = spies["schedules"]
    assert sch is not None
    assert not [t for t in spies["aims"] if sch.t_s[0] <= t < T0 + 150.0]
    # From the shove on, the aim policy decides: the moves sent are its own, not the plan's.
    aims = [t for t in spies["aims"] if T0 + 150.0 <= t <= rig.core.los_s]
    sent = [c for c in _sent(rig) if T0 + 151.0 <= c[0] <= rig.core.los_s]
    planned = [c for c in zip(sch.t_s, sch.az_m_deg, sch.el_deg, strict=True)
               if T0 + 151.0 <= c[0] <= rig.core.los_s]
    assert aims and sent and sent != planned
    assert all(any(abs(t - a) < 1e-6 for a in aims) for t, _az, _el in sent)
    late = [s.error_deg for s in rig.status if T0 + 175.0 <= s.t_s <= rig.core.los_s]
    assert max(late) <= 3.0 + 1.0                        # and brought it back in


def test_by_default_the_aim_policy_decides_every_move(spies):
    rig = Rig(track=arc_pass(duration_s=400, max_el_deg=30.0, pad_s=30))
    assert not rig.settings.planned_schedule
    assert rig.run().completed
    assert spies["schedules"] == [] and spies["aims"]
    assert track_errors(rig).max() <= 3.0 + 1.0


def test_a_high_pass_is_left_to_the_aim_policy(spies):
    # Above 45 deg the axes' split of the deadband (e_az * cos el, e_el) no longer holds
    # within a deadband; the aim policy measured fewer starts there.
    rig = Rig(track=arc_pass(duration_s=400, max_el_deg=70.0, pad_s=30), settings=PLANNED)
    assert rig.run().completed
    assert spies["schedules"] == [] and spies["aims"]
    assert track_errors(rig).max() <= 3.0 + 1.0
