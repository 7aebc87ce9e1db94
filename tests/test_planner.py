"""Mount-path planner: named cases, real passes, pre-position/park and the baseline."""

from __future__ import annotations

import itertools
import math
from functools import lru_cache

import numpy as np
import pytest
from _paths import REPO

from tracker.errors import LimitError
from tracker.geometry import boresight_horizon_ok, pointing_error_deg
from tracker.mount import preset
from tracker.planner import MountPlan, gpredict_plan, plan_pass, rate_limited_within
from tracker.skytrack import SkyTrack
from tracker.station import HorizonMask, Station
from tracker.testing import synthetic_pass

STATION = Station("test", 48.0, 11.0, 500.0)
G5500 = preset("G-5500", 50)
NORTH_360 = G5500.with_(name="north-360", az_span_deg=360)
TLE_DIR = REPO / "tle" / "data"


def assert_safe(plan: MountPlan, station: Station = STATION) -> None:
    spec = plan.spec
    assert np.all(plan.cmd_az_deg >= 0) and np.all(plan.cmd_az_deg <= spec.az_span_deg)
    assert np.all(plan.ant_az_deg >= 0) and np.all(plan.ant_az_deg <= spec.az_span_deg)
    if spec.has_elevation:
        assert np.all(plan.cmd_el_deg >= spec.el_min_deg)
        assert np.all(plan.cmd_el_deg <= spec.el_max_deg)
        assert boresight_horizon_ok(spec, station, plan.cmd_az_deg, plan.cmd_el_deg).all()
        for az, el in zip(plan.cmd_az_deg, plan.cmd_el_deg, strict=True):
            assert above_mask_by_hand(spec, station, float(az), float(el)), (az, el)
    for move in plan.preposition_moves + plan.park_moves:
        assert 0 <= move.az_deg <= spec.az_span_deg
        if spec.has_elevation:
            assert boresight_horizon_ok(spec, station, move.az_deg, move.el_deg)
            assert above_mask_by_hand(spec, station, move.az_deg, move.el_deg), move
    assert moves_clear_the_mask(plan, station)


def mask_el_by_hand(station: Station, bearing_deg: float) -> float:
    """The station's minimum elevation at a true bearing, by walking the mask's segments
    (an oracle independent of ``HorizonMask.min_el_at`` and ``Station.horizon_at``)."""
    floor = station.min_el_deg
    mask = station.mask
    if mask is None:
        return floor
    pts = list(zip(mask.az_deg, mask.min_el_deg, strict=True))
    pts = [(pts[-1][0] - 360.0, pts[-1][1]), *pts, (pts[0][0] + 360.0, pts[0][1])]
    b = bearing_deg % 360.0
    for (a0, e0), (a1, e1) in itertools.pairwise(pts):
        if a0 <= b <= a1:
            return max(floor, e0 + (e1 - e0) * (b - a0) / (a1 - a0))
    raise AssertionError(f"bearing {b} outside the mask's segments")


def above_mask_by_hand(spec, station: Station, m_az_deg: float, el_deg: float) -> bool:
    """Whether the boresight of a mount at (mechanical az, el) is at or above the mask:
    the look direction is taken from the boresight's unit vector (so an elevation over 90
    folds over the top without any special case), not from the planner's geometry."""
    bearing = math.radians(m_az_deg + spec.stop_bearing_deg)
    el = math.radians(el_deg)
    east, north, up = (math.cos(el) * math.sin(bearing), math.cos(el) * math.cos(bearing),
                       math.sin(el))
    look_el = math.degrees(math.asin(max(-1.0, min(1.0, up))))
    look_b = math.degrees(math.atan2(east, north)) % 360.0
    if math.hypot(east, north) < 1e-12:       # straight up: every bearing, and it is clear
        return True
    return look_el >= mask_el_by_hand(station, look_b) - 1e-6


def moves_clear_the_mask(plan: MountPlan, station: Station) -> bool:
    """Pre-position and park moves keep the boresight above the mask *along the way*.

    Each move must turn one axis only and be sent after the previous one has arrived (by the
    spec's rate and start delay), so the path between two commanded points is known: an
    azimuth sweep at a fixed elevation (checked over every swept degree) or an elevation
    change at a fixed azimuth (above the mask at both ends -> above it in between).
    """
    spec = plan.spec
    if not spec.has_elevation:
        return True
    tracks = ((plan.preposition_moves, plan.meta["current"]), (plan.park_moves,
              (float(plan.cmd_az_deg[-1]), float(plan.cmd_el_deg[-1]))))
    for moves, start in tracks:
        pos, ready_s = start, -np.inf
        for mv in moves:
            if pos is not None:
                d_az, d_el = abs(mv.az_deg - pos[0]), abs(mv.el_deg - pos[1])
                assert d_az < 1e-9 or d_el < 1e-9, f"two axes at once: {pos} -> {mv}"
                assert mv.t_s >= ready_s - 1e-6, "sent before the previous move arrived"
                if d_az > 1e-9:
                    swept = np.linspace(pos[0], mv.az_deg, int(d_az) + 2)
                    if not boresight_horizon_ok(spec, station, swept,
                                                np.full(len(swept), mv.el_deg)).all():
                        return False
                rate = spec.az_rate_deg_s if d_az > 1e-9 else spec.el_rate_deg_s
                ready_s = mv.t_s + spec.start_delay_s + max(d_az, d_el) / rate
            pos = (mv.az_deg, mv.el_deg)
    return True


def no_stop_crossing_while_tracking(plan: MountPlan) -> bool:
    vis = np.flatnonzero(plan.visible)
    steps = np.abs(np.diff(plan.cmd_az_deg[vis[0]:vis[-1] + 1]))
    return bool(np.all(steps < 90.0))


def test_north_crossing_pass_on_360_north_stop_flips():
    track = synthetic_pass(40, 0)  # culminates due north: crosses the north stop
    plan = plan_pass(track, NORTH_360, STATION)
    assert plan.mode == "flip"
    assert plan.max_error_deg <= 1.0 and plan.lost_track_s == 0
    assert np.all(plan.cmd_el_deg >= 90)  # over the top for the whole pass
    assert no_stop_crossing_while_tracking(plan)
    assert "flip" in plan.reason.lower() and "stop" in plan.reason
    assert_safe(plan)


def test_north_crossing_pass_on_360_north_stop_without_flip_unwinds():
    spec = NORTH_360.with_(name="n360-el90", el_max_deg=90)
    plan = plan_pass(synthetic_pass(40, 0), spec, STATION)
    assert plan.mode == "unwind"
    assert plan.lost_track_s > 0  # honest: the swing costs seconds, and they are reported
    assert plan.lost_track_s < 120
    assert_safe(plan)
    modes = {c.mode for c in plan.candidates}
    assert {"normal", "unwind"} <= modes and "flip" not in modes


def test_north_crossing_pass_on_450_uses_overlap_not_flip():
    plan = plan_pass(synthetic_pass(40, 0), G5500, STATION)
    assert plan.mode == "overlap"
    assert plan.cmd_az_deg[plan.visible].max() > 360  # in the overlap region
    assert np.all(plan.cmd_el_deg <= 90)
    assert plan.max_error_deg <= 1.0 and plan.lost_track_s == 0
    assert no_stop_crossing_while_tracking(plan)
    assert_safe(plan)
    # Gpredict's rule flips instead (it ignores the overlap when deciding)
    assert gpredict_plan(synthetic_pass(40, 0), G5500, STATION).mode == "flip"


def test_south_crossing_pass_on_south_stop_rotator():
    spec = preset("G-5400B", 50)
    plan = plan_pass(synthetic_pass(35, 180), spec, STATION)
    assert plan.mode == "flip" and plan.max_error_deg <= 1.0
    assert_safe(plan)
    # a north-crossing pass is nothing special for a south-stop rotator
    assert plan_pass(synthetic_pass(35, 0), spec, STATION).mode == "normal"


def test_89_degree_pass_uses_keyhole():
    plan = plan_pass(synthetic_pass(89, 30, 480), G5500, STATION)
    assert plan.mode == "keyhole"
    assert plan.lost_track_s == 0 and plan.max_error_deg < 3.0
    # the exact paths need an azimuth rate the rotator does not have
    exact = [c for c in plan.candidates if c.mode in ("normal", "overlap", "flip")]
    assert exact and min(c.max_error_deg for c in exact) > plan.max_error_deg
    assert np.ptp(plan.cmd_el_deg[plan.visible]) > 170  # elevation sweeps 0 -> 180
    assert_safe(plan)


def test_el_max_170_counts_the_clamped_error():
    spec = NORTH_360.with_(name="el170", el_max_deg=170)
    plan = plan_pass(synthetic_pass(40, 0), spec, STATION)
    flip = next(c for c in plan.candidates if c.mode == "flip")
    # AOS/LOS at el 0 would need 180: clamped at 170, so about 10 deg short, counted
    assert 9.0 < flip.max_error_deg < 11.0 and flip.lost_track_s > 0
    assert "clamped at 170" in flip.note
    assert np.all(plan.cmd_el_deg <= 170)
    assert_safe(plan)
    # Gpredict drops the flip entirely below 180 (its maxel >= 180 test)
    assert gpredict_plan(synthetic_pass(40, 0), spec, STATION).mode == "normal"


def test_candidates_are_ranked_and_reported():
    plan = plan_pass(synthetic_pass(40, 0), G5500, STATION)
    keys = [c.rank_key(1.0) for c in plan.candidates]
    assert keys == sorted(keys)
    summary = plan.summary()
    assert summary["mode"] == plan.mode and len(summary["candidates"]) >= 2
    assert summary["aos"] < summary["los"]


def test_preposition_and_park_are_mask_safe():
    mask = HorizonMask((0.0, 60.0, 90.0, 120.0, 300.0), (0.0, 0.0, 25.0, 0.0, 0.0))
    station = Station("masked", 48.0, 11.0, 0.0, mask=mask)
    track = synthetic_pass(50, 180)  # rises in the east-north-east... sets to the west
    plan = plan_pass(track, G5500, station, current=(0.0, 0.0))
    assert_safe(plan, station)
    # moving from north to the AOS bearing sweeps past the 25 deg obstruction at 90
    start_b = float(G5500.bearing_of(plan.preposition[0]))
    if 0 < 90 < start_b:
        assert max(m.el_deg for m in plan.preposition_moves) >= 25
    assert plan.preposition_moves[-1].az_deg == plan.preposition[0]
    assert plan.preposition_t_s + 1 < plan.t_s[plan.visible][0]
    assert plan.park_moves[-1].az_deg == G5500.park_az_deg
    assert plan.park_moves[0].t_s > plan.t_s[plan.visible][-1]


@pytest.mark.parametrize("spec, track, current", [
    (G5500, synthetic_pass(40, 0), (440.0, 0.0)),  # overlap, swept from the far end
    (preset("G-5400B", 50), synthetic_pass(35, 180), (0.0, 0.0)),  # flip: el 0 -> over the top
    (G5500, synthetic_pass(89, 30, 480), (200.0, 170.0)),  # keyhole from a flipped position
    (NORTH_360.with_(name="n360-el90", el_max_deg=90), synthetic_pass(40, 0), (300.0, 0.0)),
])
def test_preposition_and_park_sweep_over_a_wall(spec, track, current):
    # a 30 deg wall from 20 to 160 deg and a 10 deg one behind: any azimuth sweep at low
    # elevation would cross it, so every move must climb first
    mask = HorizonMask((0.0, 20.0, 160.0, 200.0, 340.0), (10.0, 30.0, 30.0, 10.0, 10.0))
    station = Station("walled", 48.0, 11.0, 0.0, mask=mask)
    if not np.any(track.el_deg >= station.horizon_at(track.az_deg)):
        pytest.skip("hidden by the mask")
    current = (current[0], min(current[1], spec.el_max_deg))
    plan = plan_pass(track, spec, station, current=current)
    assert_safe(plan, station)
    assert plan.preposition_moves and plan.park_moves


def test_mask_lifts_commands():
    mask = HorizonMask((0.0, 180.0), (15.0, 15.0))
    station = Station("walled", 48.0, 11.0, 0.0, mask=mask)
    plan = plan_pass(synthetic_pass(60, 90), G5500, station)
    assert_safe(plan, station)
    assert plan.cmd_el_deg.min() >= 15


def test_travel_from_current_position_breaks_ties():
    t = np.arange(-30.0, 331.0)  # a low pass in the NE, az 30 -> 80: fits at m and m + 360
    track = SkyTrack.from_azel(t, 30 + 50 * t / 300, 20 * np.sin(np.pi * t / 300))
    low = plan_pass(track, G5500, STATION, current=(20.0, 0.0))
    high = plan_pass(track, G5500, STATION, current=(440.0, 0.0))
    assert low.cmd_az_deg.max() <= 360 and high.cmd_az_deg.min() >= 360
    assert {low.mode, high.mode} == {"normal", "overlap"}


def test_az_only_rotator_error_is_azimuth_only():
    spec = preset("G-1000DXA")
    plan = plan_pass(synthetic_pass(50, 200), spec, STATION)
    assert np.all(plan.cmd_el_deg == 0)
    assert plan.max_error_deg <= 1.0  # the elevation of the target is not an error
    assert pointing_error_deg(spec, 10.0, 0.0, (20.0, 60.0)) == pytest.approx(10.0)


def test_current_position_outside_the_limits_is_refused():
    with pytest.raises(LimitError, match="outside the limits of rotator"):
        plan_pass(synthetic_pass(40, 0), G5500, STATION, current=(999.0, 0.0))


def test_track_below_the_mask_is_refused():
    track = SkyTrack.from_azel(np.arange(10.0), np.full(10, 90.0), np.full(10, -5.0))
    with pytest.raises(LimitError, match="never rises"):
        plan_pass(track, G5500, STATION)


@lru_cache(maxsize=1)
def _real_tracks() -> tuple[SkyTrack, ...]:
    """Every pass of three bundled amateur satellites over one day (skyfield directly)."""
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale()
    lines = (TLE_DIR / "amateur.txt").read_text().splitlines()
    sats = [EarthSatellite(lines[i + 1], lines[i + 2], lines[i].strip(), ts)
            for i in range(0, len(lines) - 2, 3)]
    topo = wgs84.latlon(STATION.lat_deg, STATION.lon_deg, elevation_m=STATION.alt_m)
    t0, t1 = ts.utc(2026, 8, 23), ts.utc(2026, 8, 24)
    tracks = []
    for sat in sats[:40:8]:
        t, events = sat.find_events(topo, t0, t1, altitude_degrees=0.0)
        rises = [t[i] for i in range(len(events) - 2) if events[i] == 0 and events[i + 2] == 2]
        sets = [t[i + 2] for i in range(len(events) - 2) if events[i] == 0
                and events[i + 2] == 2]
        for r, s in zip(rises[:3], sets[:3], strict=True):
            ts_s = np.arange(r.utc_datetime().timestamp() - 60, s.utc_datetime().timestamp()
                             + 60, 1.0)
            tt = ts.from_datetimes([__import__("datetime").datetime.fromtimestamp(
                x, __import__("datetime").timezone.utc) for x in ts_s[[0, -1]]])
            tt = ts.linspace(tt[0], tt[1], len(ts_s))
            alt, az, _ = (sat - topo).at(tt).altaz()
            tracks.append(SkyTrack.from_azel(ts_s, az.degrees, alt.degrees, name=sat.name))
    return tuple(tracks)


@pytest.mark.parametrize("spec_name", ["G-5500", "G-5400B", "generic-k3ng", "G-1000DXA"])
def test_real_passes_are_safe_and_exact_when_rates_allow(spec_name):
    spec = preset(spec_name, 50)
    tracks = _real_tracks()
    assert len(tracks) >= 5
    for track in tracks:
        plan = plan_pass(track, spec, STATION)
        assert_safe(plan)
        if plan.mode in ("normal", "overlap", "flip"):
            assert no_stop_crossing_while_tracking(plan)
        if float(np.max(track.el_deg)) < 60 and plan.mode != "unwind":
            assert plan.max_error_deg <= spec.resolution_deg, (track.name, plan.mode)


def test_a_rate_limited_path_turns_early_to_stay_within_its_band():
    # The target jumps 40 deg at t = 20 s; around the jump the path may be 20 deg off it
    # (as near the zenith), elsewhere 5 deg; the path turns at most 4 deg/s.
    t = np.arange(0.0, 40.0 + 1e-9, 0.5)
    target = np.where(t < 20.0, 0.0, 40.0)
    band = np.where((t >= 15.0) & (t <= 25.0), 20.0, 5.0)
    path = rate_limited_within(t, target, band, 4.0)
    assert path is not None
    assert np.all(np.abs(path - target) <= band + 1e-9)
    assert np.all(np.abs(np.diff(path)) <= 4.0 * 0.5 + 1e-9)
    # It must be at 20 when the target jumps: it leaves 0 five seconds before, not sooner ...
    assert path[t <= 15.0].max() == 0.0 and path[t == 15.5][0] > 0.0
    # ... and is on the target again once it can be.
    assert np.all(path[t >= 30.0] == 40.0)
    # Too slow to be within 5 deg of 40 at 25.5 s after 20 at 19.5 s: no path.
    assert rate_limited_within(t, target, band, 1.0) is None
