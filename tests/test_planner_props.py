"""Property tests: random rotators x random great-circle passes (incl. zenith, both stops)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tracker.geometry import boresight_horizon_ok
from tracker.mount import RotatorSpec
from tracker.planner import OTHER_WAY, plan_pass
from tracker.station import HorizonMask, Station
from tracker.testing import synthetic_pass

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@st.composite
def rotators(draw) -> RotatorSpec:
    el_max = draw(st.sampled_from([None, 90.0, 170.0, 180.0, 135.0]))
    return RotatorSpec(
        name="random",
        az_span_deg=draw(st.sampled_from([360.0, 450.0, 400.0])),
        stop_bearing_deg=draw(st.sampled_from([0.0, 180.0, 90.0, 270.0])),
        el_max_deg=el_max,
        el_rate_deg_s=None if el_max is None else draw(st.floats(1.0, 6.0)),
        az_rate_deg_s=draw(st.floats(1.5, 10.0)),
        start_delay_s=draw(st.sampled_from([0.0, 0.3, 0.5, 1.0])),
        park_az_deg=draw(st.sampled_from([0.0, 180.0])),
    )


@st.composite
def passes(draw):
    return synthetic_pass(
        draw(st.one_of(st.floats(3.0, 90.0), st.just(90.0), st.floats(85.0, 90.0))),
        draw(st.one_of(st.floats(0.0, 360.0), st.sampled_from([0.0, 90.0, 180.0, 270.0]))),
        draw(st.floats(240.0, 1200.0)), clockwise=draw(st.booleans()),
        pad_s=draw(st.sampled_from([20.0, 90.0])))


@st.composite
def stations(draw) -> Station:
    mask = None
    if draw(st.booleans()):
        az = sorted(draw(st.sets(st.integers(0, 359), min_size=1, max_size=5)))
        mask = HorizonMask(tuple(float(a) for a in az),
                           tuple(draw(st.floats(0.0, 20.0)) for _ in az))
    return Station("prop", 45.0, 0.0, 0.0, min_el_deg=draw(st.sampled_from([0.0, 5.0])),
                   mask=mask)


@SETTINGS
@given(spec=rotators(), track=passes(), station=stations(),
       current=st.tuples(st.floats(0, 360), st.floats(0, 90)))
def test_commands_stay_within_limits_and_mask(spec, track, station, current):
    if not np.any(track.el_deg >= station.horizon_at(track.az_deg)):
        return  # the pass is hidden by this mask: nothing to plan
    plan = plan_pass(track, spec, station, current=(current[0], current[1]))
    assert np.all((plan.cmd_az_deg >= 0) & (plan.cmd_az_deg <= spec.az_span_deg))
    assert np.all((plan.ant_az_deg >= -1e-9) & (plan.ant_az_deg <= spec.az_span_deg + 1e-9))
    if spec.has_elevation:
        assert np.all((plan.cmd_el_deg >= spec.el_min_deg)
                      & (plan.cmd_el_deg <= spec.el_max_deg))
        # the mask can only be honoured where the limits allow it (el max above the mask)
        assert boresight_horizon_ok(spec, station, plan.cmd_az_deg, plan.cmd_el_deg).all()
        for m in plan.preposition_moves + plan.park_moves:
            assert boresight_horizon_ok(spec, station, m.az_deg, m.el_deg)
        # ... and along the way: one axis at a time, each sweep above the mask
        from test_planner import moves_clear_the_mask

        assert moves_clear_the_mask(plan, station)
    for m in plan.preposition_moves + plan.park_moves:
        assert 0 <= m.az_deg <= spec.az_span_deg
    assert plan.lost_track_s <= float(np.sum(plan.visible)) + 1
    if plan.mode in ("normal", "overlap", "flip"):
        vis = np.flatnonzero(plan.visible)
        jumps = np.abs(np.diff(plan.cmd_az_deg[vis[0]:vis[-1] + 1]))
        assert np.all(jumps < 200.0), "a stop crossing while tracking"


def _required_rate(values: np.ndarray, t: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(values)) / np.diff(t))) if len(t) > 1 else 0.0


@SETTINGS
@given(spec=rotators(), track=passes())
def test_exact_paths_point_within_the_resolution_when_rates_allow(spec, track):
    station = Station("flat", 45.0, 0.0)
    plan = plan_pass(track, spec, station)
    vis = plan.visible
    # the rate a stream of 1-deg steps can sustain with the start delay before each step
    sustainable = spec.resolution_deg / (spec.start_delay_s + spec.resolution_deg
                                         / spec.az_rate_deg_s)
    t = plan.t_s[vis]
    # one command per track sample: the target may move at most ~1 step of resolution per
    # sample, or the staircase itself is coarser than the resolution
    cadence = 0.5 * spec.resolution_deg / float(np.median(np.diff(plan.t_s)))
    sustainable = min(sustainable, cadence / 0.7)
    for c in plan.candidates:
        if c.mode not in ("normal", "overlap", "flip") or not c.fits or OTHER_WAY in c.note:
            continue
        if c.mode == "flip" and spec.el_max_deg < 180:
            continue  # clamped low ends: error counted, not exact
        az_rate = _required_rate(np.unwrap(np.radians(track.az_deg[vis])) * 57.29578, t)
        el_rates_ok = True
        if spec.has_elevation:
            el_sus = spec.resolution_deg / (spec.start_delay_s + spec.resolution_deg
                                            / spec.el_rate_deg_s)
            el_rates_ok = _required_rate(track.el_deg[vis], t) <= 0.7 * min(el_sus,
                                                                             cadence / 0.7)
            if spec.el_max_deg < 90 + 1e-9 and track.el_deg.max() > spec.el_max_deg:
                continue
        if az_rate <= 0.7 * sustainable and el_rates_ok:
            assert c.max_error_deg <= spec.resolution_deg, c
            assert plan.max_error_deg <= spec.resolution_deg
            assert plan.lost_track_s == 0


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=rotators(), data=st.data())
def test_real_passes_within_limits_for_random_rotators(spec, data):
    from test_planner import STATION, _real_tracks

    tracks = _real_tracks()
    track = tracks[data.draw(st.integers(0, len(tracks) - 1))]
    plan = plan_pass(track, spec, STATION)
    assert np.all((plan.cmd_az_deg >= 0) & (plan.cmd_az_deg <= spec.az_span_deg))
    if spec.has_elevation:
        assert np.all((plan.cmd_el_deg >= 0) & (plan.cmd_el_deg <= spec.el_max_deg))
        assert boresight_horizon_ok(spec, STATION, plan.cmd_az_deg, plan.cmd_el_deg).all()
    if plan.mode in ("normal", "overlap", "flip"):
        vis = np.flatnonzero(plan.visible)
        assert np.all(np.abs(np.diff(plan.cmd_az_deg[vis[0]:vis[-1] + 1])) < 200.0)
