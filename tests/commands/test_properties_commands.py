"""Property tests: random rotator specs x random passes x random horizon masks → every
command the live loop would stream and every point a step table would hold stays within the
rotator's limits and above the horizon mask.

The live loop's decision core (:class:`tracker.stream.TrackCore`) runs against THE motor model
as the antenna (no port: the wire is covered by the fault tests); the step-table compiler
runs on the planner's path (:func:`tracker.steptable.compile_pass`).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_planner_props import passes, rotators, stations

from tracker.errors import ConfigError, LimitError
from tracker.mount import MotorModel
from tracker.planner import plan_pass
from tracker.steptable import compile_pass
from tracker.stream import Phase, StreamSettings, TrackCore


def target(what: str, n: int) -> None:
    event(f"{what} checked")

PROPS = settings(max_examples=25, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
CYCLE_S = 1.0


def _look(spec, az_m, el):
    """Where the boresight looks: (bearing, elevation); over the top past 90 deg."""
    b = float(spec.bearing_of(az_m))
    return ((b + 180.0) % 360.0, 180.0 - el) if el > 90.0 else (b % 360.0, el)


def _floor(station, bearing, half_width=0.0):
    """The mask's lowest point within ``half_width`` of ``bearing`` (wire rounding)."""
    bs = np.array([bearing - half_width, bearing, bearing + half_width]) % 360.0
    return float(np.min(station.horizon_at(bs)))


def _visible(track, station) -> bool:
    return bool(np.any(track.el_deg >= station.horizon_at(track.az_deg) + 1.0))


@PROPS
@given(spec=rotators(), track=passes(), station=stations(),
       start=st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 60.0)))
def test_streamed_commands_stay_within_limits_and_mask(spec, track, station, start):
    if not _visible(track, station):
        return
    az0 = start[0] * spec.az_span_deg
    el0 = None if not spec.has_elevation else min(start[1], spec.el_max_deg)
    plan = plan_pass(track, spec, station, current=(az0, el0 or 0.0))
    core = TrackCore(plan, track, spec, station,
                     StreamSettings(deadband_deg=3.0, cycle_s=CYCLE_S))
    t = min(float(plan.preposition_t_s), float(track.t_s[0])) - 1.0
    motor = MotorModel(spec, az0, el0, t_s=t)
    end = float(track.t_s[-1]) + 400.0
    sent = 0
    while core.phase is not Phase.DONE and t < end:
        az_m, el = motor.position(t)
        wire_az = round(spec.frame.wire_of(float(az_m)))
        core.observe(t, float(wire_az), None if el0 is None else float(round(el)))
        cmd = core.decide(t)
        if cmd is not None:
            sent += 1
            assert -1e-9 <= cmd.az_m_deg <= spec.az_span_deg + 1e-9, cmd
            if spec.has_elevation:
                assert spec.el_min_deg - 1e-9 <= cmd.el_deg <= spec.el_max_deg + 1e-9, cmd
                b, look_el = _look(spec, cmd.az_m_deg, cmd.el_deg)
                floor = float(station.horizon_at(b))
                if spec.el_max_deg >= floor:      # honourable only where the limits allow
                    assert look_el >= floor - 1e-6, (cmd, floor)
                    # and on the wire, whole degrees: rounding loses at most half a degree
                    wb, wel = _look(spec, round(cmd.az_m_deg), round(cmd.el_deg))
                    assert wel >= _floor(station, wb, 0.5) - 0.5 - 1e-6, (cmd, wb, wel)
            motor.command(cmd.az_m_deg, cmd.el_deg, t)
            core.commanded(t, cmd)
        t += CYCLE_S
    assert core.phase is Phase.DONE, core.phase
    assert sent >= 1
    target("commands", sent)


@PROPS
@given(spec=rotators(), track=passes(), station=stations(),
       profile=st.sampled_from(["gs232b", "k3ng", "gs232a"]),
       interval=st.sampled_from([None, 1, 2, 5, 10]))
def test_tabled_points_stay_within_limits_and_mask(spec, track, station, profile, interval):
    if not _visible(track, station):
        return
    try:
        prog = compile_pass(track, spec, station, profile, interval_s=interval)
    except (ConfigError, LimitError):
        return          # refused up front with a message (e.g. too many points): fine
    for table in prog.tables:
        az = np.asarray(table.az_deg, dtype=float)
        assert np.all((az >= 0) & (az <= spec.az_span_deg)), table.az_deg
        assert np.all(az == np.round(az))
        if table.el_deg is None:
            continue
        el = np.asarray(table.el_deg, dtype=float)
        assert np.all((el >= spec.el_min_deg) & (el <= spec.el_max_deg)), table.el_deg
        for a, e in zip(az, el, strict=True):
            b, look_el = _look(spec, a, e)
            floor = _floor(station, b, 0.5)
            if spec.el_max_deg >= floor:
                assert look_el >= floor - 0.5 - 1e-6, (a, e, floor)
        table.lines()      # encodes within the profile's line and point limits
    target("tables", len(prog.tables))
