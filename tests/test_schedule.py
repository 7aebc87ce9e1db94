"""The whole-pass command schedule (tracker/schedule.py) and the live loop following it, on
virtual time: planned knowing the pass, checked through THE motor model, handed to the aim
policy when the read-back leaves it."""

from __future__ import annotations

from dataclasses import replace
from itertools import pairwise

import numpy as np
import pytest
from _stream_fakes import T0, arc_pass, simple_plan
from test_stream import Rig, track_errors

import tracker.stream as stream_mod
from tracker import compiled
from tracker.fewest_starts import fewest_starts
from tracker.geometry import MountPath
from tracker.mount import MotorModel, bends_s, drive_axis, preset
from tracker.planner import plan_pass
from tracker.schedule import plan_schedule
from tracker.skytrack import SkyTrack
from tracker.startbound import start_lower_bound
from tracker.station import HorizonMask, Station
from tracker.stream import Phase, StreamSettings, TrackCore
from tracker.targets import SatelliteTarget

SPEC = preset("G-5500", 50)
PLANNED = StreamSettings(deadband_deg=3.0, planned_schedule=True)


def _rest_on_path(path: MountPath, t_s: float) -> MotorModel:
    az, el = path.mount_at(t_s)
    return MotorModel(SPEC, round(float(az)), round(float(el)), t_s)


def test_a_slow_target_needs_one_start_per_two_degrees_of_travel():
    # The target runs 0.4 deg/s along el 10 for 60 s, 100 -> 124 deg. The programme keeps
    # 1.1 deg less half the target's travel between samples (0.05 deg): 1.066 deg of azimuth
    # at el 10, so resting on a whole degree q holds the target within q -+ 1.066 and
    # consecutive rests are at most 2 deg apart: 12 starts at the least, and the programme
    # must find a schedule that needs no more.
    ts = np.arange(T0, T0 + 60.0 + 1e-9, 0.25)
    path = MountPath.from_arrays(ts, 100.0 + 0.4 * (ts - T0), np.full_like(ts, 10.0), SPEC)
    motor = MotorModel(SPEC, 100.0, 10.0, T0)
    found = fewest_starts(path, motor.az, motor.el, T0, T0 + 60.0, 1.1)
    assert found is not None and found.starts == 12
    assert all(round((t - T0) / 0.5, 9) % 1 == 0 for t, _a, _e in found.commands)  # on cycles
    assert all(e is None for _t, _a, e in found.commands)      # the elevation never moves
    # The relaxed bound (rests anywhere, not only on whole degrees) is below it.
    bound = start_lower_bound(SPEC, ts, *path.mount_at(ts), *path.mount_at(ts), 1.1,
                              park=(100.0, 10.0))
    assert bound is not None and bound <= found.starts


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
    # Near the clairvoyant lower bound (no schedule needs fewer; the bound keeps the band at
    # its samples only, the schedule between them too).
    bearing, target_el = track.direction_at(ts)
    p_az, p_el = path.mount_at(ts)
    bound = start_lower_bound(SPEC, ts, bearing, target_el, p_az, p_el, 2.8,
                              park=(float(motor.az.position(t0)), float(motor.el.position(t0))))
    assert bound is not None and bound <= sch.starts <= 1.2 * bound


def test_a_free_start_may_begin_anywhere_for_one_start_per_axis():
    track = arc_pass(duration_s=300, max_el_deg=30.0, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    park = MotorModel(SPEC, 0.0, 0.0, T0)
    assert fewest_starts(path, park.az, park.el, T0, T0 + 300.0, 2.5) is None  # 100 deg off
    found = fewest_starts(path, park.az, park.el, T0, T0 + 300.0, 2.5, free_start=True)
    assert found is not None and found.start_az_deg > 90.0
    moved = (found.start_az_deg != 0.0) + (found.start_el_deg != 0.0)   # el 0 keeps AOS
    there = MotorModel(SPEC, found.start_az_deg, found.start_el_deg, T0)
    again = fewest_starts(path, there.az, there.el, T0, T0 + 300.0, 2.5)
    assert again is not None and again.starts == found.starts - moved
    # Before ``from_s`` the band is not asked for: an antenna just off it may plan to come in.
    t1 = T0 + 100.0
    az, el = (float(x) for x in path.mount_at(t1))
    off = MotorModel(SPEC, round(az) + 2.0, round(el) + 2.0, t1)
    assert path.error_deg(t1, off.az.position(t1), off.el.position(t1)) > 2.5
    assert fewest_starts(path, off.az, off.el, t1, t1 + 60.0, 2.5) is None
    late = fewest_starts(path, off.az, off.el, t1, t1 + 60.0, 2.5, from_s=t1 + 2.5)
    assert late is not None


@pytest.mark.parametrize("max_el_deg", [25.0, 60.0, 88.0])
def test_the_compiled_programme_finds_the_same_schedule_as_numpy(max_el_deg):
    """The programme's two implementations (numpy, and loops numba compiles) take the same
    steps: the same schedule, command for command, from a free start and from ``from_s``, and
    the same None where no schedule of the class keeps the band."""
    pytest.importorskip("numba")
    track = arc_pass(duration_s=420, max_el_deg=max_el_deg, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    park = MotorModel(SPEC, 0.0, 0.0, T0)
    there = _rest_on_path(path, T0)
    # The compiled loops store samples alternately az-major and el-major: spans of an even
    # and an odd number of steps end on either.
    cases = [(park, 2.0, None, True, 420.0), (park, 4.0, None, True, 420.0),
             (park, 2.0, None, True, 419.75), (there, 3.0, T0 + 4.0, False, 420.0),
             (there, 3.0, T0 + 4.0, False, 419.75), (park, 3.0, None, False, 420.0)]
    for motor, band_deg, from_s, free_start, span_s in cases:
        got = {}
        for name in ("numpy", "numba"):
            previous = compiled.use(name)
            try:
                got[name] = fewest_starts(path, motor.az, motor.el, T0, T0 + span_s, band_deg,
                                          from_s=from_s, free_start=free_start)
            finally:
                compiled.use(previous)
        assert got["numba"] == got["numpy"], (band_deg, from_s, free_start, span_s)
        assert (got["numpy"] is None) == (motor is park and not free_start)


def test_the_schedule_samples_fall_on_the_loops_cycles_to_the_end():
    # At epoch seconds a 0.05 s np.arange step rounds to 0.24 us and the grid drifts: the
    # last sample fell 0.16 ms before the loop's last cycle, which then found the schedule
    # over and sent the aim policy's command at LOS, a start for nothing.
    track = arc_pass(duration_s=600, max_el_deg=35.0, pad_s=30)
    path = MountPath.from_track(track, SPEC)
    t0 = T0 + 0.46
    assert t0 > 1e9
    motor = _rest_on_path(path, t0)
    sch = plan_schedule(path, motor.az, motor.el, t0, t0 + 580.0, 2.8)
    assert sch is not None
    cycles = t0 + 0.25 * np.arange(len(sch.sample_t_s))
    assert np.max(np.abs(sch.sample_t_s - cycles)) < 1e-6
    assert sch.end_s == pytest.approx(t0 + 580.0, abs=1e-6)


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


def test_by_default_the_schedule_decides_and_saves_starts_over_the_aim_policy(spies):
    # A 70 deg pass: the whole-pass schedule keeps the deadband with fewer motor starts than
    # the aim policy deciding one move at a time.
    track = arc_pass(duration_s=400, max_el_deg=70.0, pad_s=30)
    planned = Rig(track=track)
    assert planned.settings.planned_schedule and planned.run().completed
    (sch,) = spies["schedules"]
    assert sch is not None
    alone = Rig(track=track, settings=StreamSettings(deadband_deg=3.0, planned_schedule=False))
    assert alone.run().completed
    assert spies["schedules"] == [sch] and spies["aims"]
    starts = [_starts(rig) for rig in (planned, alone)]
    assert starts[0] < starts[1]
    for rig in (planned, alone):
        assert track_errors(rig).max() <= 3.0 + 1.0      # deadband + integer read-back


def _starts(rig) -> int:
    """Motor starts of every command the rig's rotator was sent, through the motor model."""
    sent = _sent(rig)
    motor = MotorModel(SPEC, 90.0, 0.0, T0 - 60.0)
    t = [c[0] for c in sent]
    return (drive_axis(motor.az, t, [c[1] for c in sent], t)[1]
            + drive_axis(motor.el, t, [c[2] for c in sent], t)[1])


def test_planned_before_the_pre_position_which_goes_to_the_schedules_start(spies):
    rig = Rig(track=arc_pass(duration_s=400, max_el_deg=30.0, pad_s=30))
    assert rig.run().completed
    (sch,) = spies["schedules"]
    assert sch is not None and sch.sample_t_s[0] <= rig.core.track_from_s
    # Free to start anywhere: the pre-position's (only) move went where the schedule starts.
    first = _sent(rig)[0]
    assert first[0] < sch.sample_t_s[0]
    assert (first[1], first[2]) == (sch.az_pos_deg[0], sch.el_pos_deg[0])


def test_a_reconnect_before_the_pass_plans_the_schedule_again():
    track = arc_pass(duration_s=400, max_el_deg=30.0, pad_s=30)
    rig = Rig(track=track)
    core = rig.core
    t = core.preposition_t_s - 5.0
    core.observe(t, 90.0, 0.0)
    assert core.decide(t) is None and core._schedule is not None      # waiting, planned
    core.resync()                                                     # the port came back
    assert core._schedule is None
    core.observe(t + 0.5, 90.0, 0.0)
    core.decide(t + 0.5)
    assert core._schedule is not None


@pytest.mark.parametrize("resolution_deg, grid_deg", [(2.0, 2.0), (0.1, 1.0), (4 / 6, 4 / 3)])
def test_targets_are_what_the_controller_can_take(resolution_deg, grid_deg):
    # A controller that takes 2 deg steps (or 0.1, or 2/3) gets targets on its own grid,
    # about a degree apart or coarser, and the schedule keeps the band as planned.
    spec = replace(SPEC, resolution_deg=resolution_deg)
    track = arc_pass(duration_s=300, max_el_deg=30.0, pad_s=30)
    path = MountPath.from_track(track, spec)
    az, el = (float(x) for x in path.mount_at(T0))
    motor = MotorModel(spec, grid_deg * round(az / grid_deg), grid_deg * round(el / grid_deg),
                       T0)
    sch = plan_schedule(path, motor.az, motor.el, T0, T0 + 300.0, 3.0)
    # (the peak within the rounding plan_schedule allows)
    assert sch is not None and sch.peak_error_deg <= 3.0 + 1e-6 and sch.starts > 0
    for q in (*sch.az_m_deg, *sch.el_deg):
        assert abs(q / grid_deg - round(q / grid_deg)) < 1e-6


def test_after_a_fast_stretch_it_cannot_keep_the_rest_of_the_pass_is_planned_again(spies):
    # At el 20 the target's azimuth jumps 60 deg in 6 s (10 deg/s, twice the motor's rate)
    # halfway through the pass: no schedule keeps the band there, the plan's own commands take
    # over, and after the jump the rest of the pass gets a schedule of its own.
    t = np.arange(T0 - 30.0, T0 + 330.0 + 0.5, 1.0)
    f = (t - T0) / 300.0
    jump = np.clip((t - (T0 + 150.0)) / 6.0, 0.0, 1.0)
    az = 100.0 + 40.0 * f + 60.0 * jump
    el = 20.0 * np.sin(np.pi * np.clip(f, -0.05, 1.05)) + np.where(f < 0, -1.0, 0.0)
    rig = Rig(track=SkyTrack.from_azel(t, az, el, name="JUMP"))
    assert rig.run().completed
    plans = [s for s in spies["schedules"] if s is not None]
    assert len(plans) == 2, [None if s is None else s.end_s - T0 for s in spies["schedules"]]
    first, second = plans
    assert first.end_s < T0 + 150.0 < T0 + 156.0 < second.sample_t_s[0]
    assert second.end_s == pytest.approx(rig.core.los_s, abs=0.5)


def test_a_target_out_of_the_axes_reach_gets_no_schedule_and_no_error():
    # The target sinks to el -10 (at once, or by and by): where no elevation the axis can take
    # is within reach, no schedule of the class exists (the loop's aim policy goes on).
    ts = np.arange(T0, T0 + 60.0 + 1e-9, 0.25)
    for el in (np.full_like(ts, -10.0), np.maximum(5.0 - 0.25 * (ts - T0), -10.0)):
        path = MountPath.from_arrays(ts, np.full_like(ts, 100.0), el, SPEC)
        motor = MotorModel(SPEC, 100.0, 0.0, T0)
        assert fewest_starts(path, motor.az, motor.el, T0, T0 + 60.0, 2.0) is None
        assert plan_schedule(path, motor.az, motor.el, T0, T0 + 60.0, 2.0) is None


def test_a_pre_position_of_several_moves_turns_each_axis_once_to_the_schedules_start():
    # The antenna rests at el 30 over a 10 deg mask: the mask-safe sequence turns the
    # azimuth across at that height, then sets the elevation. Aimed at the plan's start, it
    # turned the azimuth there, and the last move on to the schedule's start: two azimuth
    # starts where one does.
    station = Station(mask=HorizonMask((0.0, 180.0), (10.0, 10.0)))
    track = arc_pass(duration_s=400, max_el_deg=40.0, pad_s=120)
    here = (SPEC.park_az_deg, 30.0)
    plan = plan_pass(track, SPEC, station, current=here)
    assert [m.el_deg for m in plan.preposition_moves] == [30.0, plan.preposition[1]]
    core = TrackCore(plan, track, SPEC, station, PLANNED)
    t = core.preposition_t_s - 5.0
    truth = MotorModel(SPEC, *here, t)
    pre = []
    while t < core.track_from_s:
        core.observe(t, truth.az.position(t), truth.el.position(t))
        cmd = core.decide(t)
        if cmd is not None:
            core.commanded(t, cmd)
            truth.command(cmd.az_m_deg, cmd.el_deg, t)
            pre.append((cmd.az_m_deg, cmd.el_deg))
        t += 0.5
    sch = core._schedule
    assert sch is not None and pre[-1] == (sch.az_pos_deg[0], sch.el_pos_deg[0])
    assert pre[-1][0] != plan.preposition[0]          # the schedule starts elsewhere
    azs = [here[0]] + [az for az, _el in pre]
    assert sum(a != b for a, b in pairwise(azs)) == 1     # one azimuth move


def test_a_schedule_cut_before_a_fast_stretch_hands_over_a_lookahead_before_its_end():
    # It keeps the band only up to its end: handed over at the end, the aim policy's first
    # move came a cycle late, its start delay still to run (a keyhole pass at 5 deg lost
    # 0.25 s so). The aim policy decides from a lookahead before the end.
    t = np.arange(T0 - 30.0, T0 + 330.0 + 0.5, 1.0)
    f = (t - T0) / 300.0
    jump = np.clip((t - (T0 + 150.0)) / 6.0, 0.0, 1.0)
    az = 100.0 + 40.0 * f + 60.0 * jump
    el = 20.0 * np.sin(np.pi * np.clip(f, -0.05, 1.05)) + np.where(f < 0, -1.0, 0.0)
    track = SkyTrack.from_azel(t, az, el, name="JUMP")
    core = TrackCore(simple_plan(track, SPEC), track, SPEC, Station(), PLANNED)
    now = core.preposition_t_s - 5.0
    truth = MotorModel(SPEC, 90.0, 0.0, now)
    first = None
    while now < T0 + 150.0:
        core.observe(now, truth.az.position(now), truth.el.position(now))
        cmd = core.decide(now)
        if cmd is not None:
            core.commanded(now, cmd)
            truth.command(cmd.az_m_deg, cmd.el_deg, now)
        first = first or core._schedule
        if first is not None and now > first.end_s - core._lookahead_s:
            break
        now += 0.5
    assert first is not None and first.end_s < core.los_s - 60.0     # cut before the jump
    assert now <= first.end_s and core._schedule is None


def _real_pass(line1: str, line2: str, station: Station, t0_s: float, t1_s: float, D: float):
    """A real pass from its elements (skyfield), the live loop's path and its schedule as
    the loop plans it before the pre-position: from park, free to start anywhere, the band
    kept from the start of tracking."""
    track = SatelliteTarget.from_lines(line1, line2).observe(
        station, np.arange(t0_s, t1_s + 1e-9, 1.0))
    plan = plan_pass(track, SPEC, station, current=(SPEC.park_az_deg, SPEC.park_el_deg))
    core = TrackCore(plan, track, SPEC, station, StreamSettings(deadband_deg=D))
    t0 = core.track_from_s - 0.5
    park = MotorModel(SPEC, SPEC.park_az_deg, SPEC.park_el_deg, t0)
    band = D - stream_mod.SCHEDULE_MARGIN_DEG
    sch = plan_schedule(core.path, park.az, park.el, t0, core.los_s, band,
                        from_s=core.track_from_s, free_start=True)
    return core, sch, band


def _driven(sch, t0_s: float, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The schedule's az / el over ``ts``, from its start (a free start rests there)."""
    start = MotorModel(SPEC, float(sch.az_pos_deg[0]), float(sch.el_pos_deg[0]), t0_s)
    return (drive_axis(start.az, sch.t_s, sch.az_m_deg, ts)[0],
            drive_axis(start.el, sch.t_s, sch.el_deg, ts)[0])


def test_the_schedule_keeps_the_band_where_an_axis_stops_between_two_checks():
    # TIANMU-1 14 from Fairbanks (max el 9.5) at D = 3.5: checked on its 0.05 s grid alone,
    # the schedule passed, yet where an axis stopped between two checks the antenna was
    # 0.003 deg outside the band (on the streaming benchmark's track, at D = 5, 5.002 deg off:
    # a lost-target sample). Every instant an axis starts or stops is checked too now.
    fairbanks = Station("Fairbanks", 65.0, -147.7, 150.0)
    core, sch, band = _real_pass(
        "1 58648U 23205D   26234.61442690  .00004809  00000+0  18261-3 0  9993",
        "2 58648  97.3404 254.3037 0008978  98.5902 261.6355 15.27259369147648",
        fairbanks, 1787637015.0, 1787637663.0, 3.5)
    assert sch is not None
    t0 = float(sch.sample_t_s[0])
    start = MotorModel(SPEC, float(sch.az_pos_deg[0]), float(sch.el_pos_deg[0]), t0)
    bends = np.sort(np.concatenate((bends_s(start.az, sch.t_s, sch.az_m_deg),
                                    bends_s(start.el, sch.t_s, sch.el_deg))))
    bends = bends[(bends >= core.track_from_s) & (bends <= sch.end_s)]
    az, el = _driven(sch, t0, bends)
    err = core.path.error_deg(bends, az, el)
    assert len(bends) > 10 and float(np.max(err)) <= band + 1e-6
    assert float(np.max(err)) <= sch.peak_error_deg + 1e-9


def test_near_the_zenith_the_schedule_lets_the_azimuth_lag_far_behind_the_target():
    # UWE-3 from Singapore (max el 85.6): near the culmination the target's azimuth runs at
    # up to 10 deg/s, twice the motor's 5.17. At el 84 an azimuth 40 deg behind is 4 deg on
    # the sky: the schedule keeps 5 deg through it with the azimuth lagging more than 15 deg
    # (where the positions searched once stopped, and the pass had no schedule: the aim policy
    # then lost the target for 10 s).
    singapore = Station("Singapore", 1.35, 103.8, 20.0)
    core, sch, band = _real_pass(
        "1 39446U 13066AG  26233.84454598  .00003579  00000+0  30520-3 0  9991",
        "2 39446  97.8761 190.3966 0050533  99.8600 260.8332 14.97397967687409",
        singapore, 1787816381.0, 1787817241.0, 5.0)
    assert sch is not None and sch.end_s >= core.los_s - 0.5
    ts = np.arange(core.track_from_s, sch.end_s, 0.05)
    az, el = _driven(sch, float(sch.sample_t_s[0]), ts)
    assert float(np.max(core.path.error_deg(ts, az, el))) <= band + 1e-6
    lag = np.abs(az - core.path.mount_at(ts)[0])
    assert float(np.max(lag)) > 15.0
