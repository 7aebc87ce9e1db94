"""``tracker.tracking``: following passes as a library, on virtual time.

One antenna follows two ISS passes on the in-process GS-232B emulator (a ManualClock shared
with the loop), parking in between and re-planning pass 2 from the read-back; the demo's time
policy pauses while an antenna plans and skips idle time only when every antenna waits; two
antennas share one GS-232B-AZ/AZ port (a LockstepClock) and plan inside the controller's
limits; and ``examples/follow_passes.py`` runs.
"""

from __future__ import annotations

import runpy
import threading
from datetime import datetime, timedelta, timezone
from functools import partial

import pytest
from _paths import REPO
from _virtual import manual_clock, virtual_rig

from tracker.api import (
    Bench,
    Catalog,
    ControllerSession,
    DemoTime,
    LockstepClock,
    PassFollower,
    SharedAzAz,
    SimClock,
    Station,
    StreamSettings,
    TrackerError,
    demo_speed,
    demo_start,
    driver_limits,
    follow_passes,
    follow_together,
    make_controller,
    next_pass,
    open_driver,
    park_position,
    preset,
    resolve_target,
    utc,
)
from tracker.emulator.azaz_controller import AzAzController

STATION = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0)
# A read-back every 2 s: the idle stretch between two ISS passes costs a quarter of the
# cycles of the CLI's 0.5 s, and the deadband still holds.
SETTINGS = StreamSettings(deadband_deg=4.0, cycle_s=2.0)


@pytest.fixture(scope="module")
def catalog():
    return Catalog.bundled_snapshot()


class Recorder:
    """An event sink that keeps ``(t_s, kind, data)`` on the loop's clock."""

    def __init__(self, clock):
        self.clock = clock
        self.events: list[tuple[float, str, dict]] = []

    def __call__(self, kind: str, **data) -> None:
        self.events.append((self.clock.timestamp(), kind, data))

    def of(self, kind: str, **match) -> list[tuple[float, dict]]:
        return [(t, d) for t, k, d in self.events
                if k == kind and all(d.get(key) == v for key, v in match.items())]

    def infos(self) -> list[str]:
        return [d["text"] for _t, d in self.of("info")]


def test_two_passes_with_a_park_in_between(catalog):
    iss = resolve_target("ISS (ZARYA)", catalog)
    spec = preset("G-5500")
    first = next_pass(iss, STATION, utc(2026, 8, 22, 12).timestamp())
    second = next_pass(iss, STATION, first.los.timestamp() + 60.0)
    clock = manual_clock(first.aos.timestamp() - 180.0)
    rig = virtual_rig(make_controller("gs232b", clock, rotator="G-5500", az_deg=0.0,
                                      el_deg=0.0))
    rec = Recorder(clock)
    try:
        results = follow_passes(
            iss, lambda: open_driver(rig.url, "gs232b", clock=clock, **driver_limits(spec)),
            spec, STATION, clock, SETTINGS, passes=2, first=first, events=rec)
        wire = rig.written()
    finally:
        rig.close()
    assert len(results) == 2 and all(r.completed for r in results)
    for res in results:
        assert res.max_error_deg <= 4.0 + 1.0, res.max_error_deg
    plans = rec.of("state", state="plan")
    assert [d["aos"] for _t, d in plans] == [first.aos.isoformat(), second.aos.isoformat()]
    # Parked after pass 1, before pass 2 was planned ...
    park_az, park_el = park_position(spec, STATION)
    parks = [(t, d) for t, d in rec.of("command", cmd="goto", reason="park")
             if first.los.timestamp() <= t < plans[1][0]]
    assert parks and (parks[-1][1]["az_m"], parks[-1][1]["el"]) == (park_az, park_el)
    # ... and pass 2 planned from the antenna's read-back there, not from an assumption.
    replies = [d for t, d in rec.of("reply") if t <= plans[1][0]]
    assert abs(replies[-1]["az"] - park_az) <= 1.0 and abs(replies[-1]["el"] - park_el) <= 1.0
    second_moves = [d for t, d in rec.of("command", cmd="goto") if t > plans[1][0]]
    assert second_moves[0]["reason"] == "preposition"
    assert clock.timestamp() >= second.los.timestamp()
    assert [s.split(":")[0] for s in rec.infos() if " done:" in s] == ["pass 1 done",
                                                                        "pass 2 done"]
    assert wire.endswith(b"S\r")              # all-stop is the last thing on the wire


def test_follower_stops_when_asked_and_keeps_no_result_for_the_cut_pass(catalog):
    iss = resolve_target("ISS (ZARYA)", catalog)
    spec = preset("G-5500")
    first = next_pass(iss, STATION, utc(2026, 8, 22, 12).timestamp())
    clock = manual_clock(first.aos.timestamp() - 60.0)
    rig = virtual_rig(make_controller("gs232b", clock, rotator="G-5500"))
    follower = PassFollower(
        iss, lambda: open_driver(rig.url, "gs232b", clock=clock, **driver_limits(spec)),
        spec, STATION, clock, SETTINGS, first=first)
    try:
        with ControllerSession(follower.stop, stop_at_end=False):
            results = follower.run(
                passes=0, should_stop=lambda: clock.timestamp() > first.aos.timestamp())
    finally:
        follower.close()
        wire = rig.written()
        rig.close()
    assert results == [] and clock.timestamp() < first.los.timestamp()
    assert wire.endswith(b"S\r")


# The demo's time ---------------------------------------------------------------------------


def test_demo_time_is_paused_while_antennas_plan_and_skips_only_when_all_wait():
    t0 = datetime(2026, 8, 23, 2, 0, tzinfo=timezone.utc)
    clock = SimClock(t0, speed=1.0)
    timer = DemoTime(clock, [1, 2])
    a = clock.timestamp()
    assert clock.timestamp() == a              # both antennas plan first: time stands still
    timer.release(1)
    assert clock.timestamp() == a              # antenna 2 still plans
    timer.release(2)
    said: list[tuple[int, str]] = []
    start_s = clock.timestamp()
    # Antenna 1 waits an hour for its pass; it may not skip while antenna 2 still tracks.
    t1 = threading.Thread(target=timer.idle_until, args=(
        1, start_s + 3600.0, lambda text: said.append((1, text)), lambda: False))
    t1.start()
    # Antenna 2 then waits half an hour: both idle, so the clock skips to the earlier wake-up.
    timer.idle_until(2, start_s + 1800.0, lambda text: said.append((2, text)), lambda: False)
    assert start_s + 1800.0 <= clock.timestamp() < start_s + 1810.0
    assert t1.is_alive()                      # antenna 1 waits for its own pass
    timer.leave(2)                             # antenna 2 is done: antenna 1 skips the rest
    t1.join(timeout=10.0)
    assert not t1.is_alive()
    assert start_s + 3600.0 <= clock.timestamp() < start_s + 3610.0
    texts = [text for _n, text in said]
    assert texts == ["skipping 30 min of simulated idle time to the next pass"] * 2, said


def test_demo_time_does_not_skip_short_gaps_nor_while_an_antenna_plans():
    clock = SimClock(datetime(2026, 8, 23, 2, 0, tzinfo=timezone.utc), speed=1000.0)
    timer = DemoTime(clock, [0])
    timer.release(0)
    said: list[str] = []
    t = clock.timestamp()
    timer.idle_until(0, t + 20.0, said.append, lambda: False)   # under IDLE_SKIP_MIN_S
    assert said == [] and clock.timestamp() >= t + 20.0
    timer.hold(0)
    frozen = clock.timestamp()
    stops = iter([False, True])
    timer.idle_until(0, frozen + 3600.0, said.append, lambda: next(stops))
    assert said == [] and clock.timestamp() == frozen           # planning: no skip, paused


def test_demo_start_replays_a_pass_near_the_epoch_of_stale_elements(catalog):
    iss = resolve_target("ISS (ZARYA)", catalog)
    epoch = iss.elements.epoch
    fresh = epoch + timedelta(days=2)
    assert demo_start(iss, fresh) == (fresh, "")
    start, note = demo_start(iss, epoch + timedelta(days=40))
    assert start == epoch and "40 days old" in note and "replays a pass" in note
    first = next_pass(iss, STATION, start.timestamp())
    # the longest first pass (from 2 min before AOS) shows in about a minute of wall time
    span_s = first.los.timestamp() - (first.aos.timestamp() - 120.0)
    assert demo_speed([first], start) == max(1.0, round(span_s / 60.0))


# Two antennas on one GS-232B-AZ/AZ port -------------------------------------------------------


def test_two_antennas_on_one_azaz_port_plan_inside_its_limits(catalog):
    """A 450 deg azimuth rotator on each AZ/AZ antenna: the interface takes 0-360 only, so
    both plan inside 360 (UO-11's pass would want the overlap, a move to 372 the box refuses)."""
    spec = preset("G-1000DXA")
    targets = [resolve_target(n, catalog) for n in ("ISS (ZARYA)", "UOSAT 2 (UO-11)")]
    start_s = utc(2026, 8, 23, 3, 40).timestamp()
    firsts = [next_pass(t, STATION, start_s) for t in targets]
    clock = LockstepClock(datetime.fromtimestamp(start_s, timezone.utc), parties=2)
    ctrl = AzAzController(spec, spec, clock)
    bench = Bench(ctrl)
    shared = SharedAzAz(partial(open_driver, bench.url, "gs232b-azaz", clock=clock,
                                **driver_limits(spec)))
    run_rec = Recorder(clock)
    recs = [Recorder(clock), Recorder(clock)]
    followers = [PassFollower(t, partial(shared.axis, n), spec, STATION, clock,
                              StreamSettings(deadband_deg=3.0), events=rec, antenna=n,
                              first=first)
                 for n, t, first, rec in zip((1, 2), targets, firsts, recs, strict=True)]
    try:
        with ControllerSession(partial(shared.session_stop, run_rec), stop_at_end=False):
            follow_together(followers, shared, passes=1, events=run_rec)
        wire = bench.bytes_written()
    finally:
        for f in followers:
            f.close()
        shared.close()
        bench.close()
    lines = [line.strip() for line in wire.split(b"\r") if line.strip()]
    for f, rec in zip(followers, recs, strict=True):
        assert len(f.results) == 1 and f.results[0].completed
        assert f.spec.az_span_deg == 360.0 and f.label.startswith(f"ant{f.antenna} ")
        assert any(s.startswith("planning inside the controller's limits: az 0-360")
                   for s in rec.infos())
        (_t, plan), = rec.of("state", state="plan")
        assert plan["mode"] != "overlap"
        assert all(d["az"] <= 360.0 for _t, d in rec.of("command", cmd="goto"))
    n_m = sum(c.startswith(b"M") and not c.startswith(b"MB") for c in lines)
    n_mb = sum(c.startswith(b"MB") for c in lines)
    assert (n_m, n_mb) == tuple(len(r.of("command", cmd="goto")) for r in recs)
    assert lines[-1] == b"S" and b"S" not in lines[:-1]   # one S, the run's last word
    assert run_rec.of("command", cmd="stop", note="S: both antennas")


def test_an_error_on_one_antenna_stops_both_and_names_it(catalog):
    spec = preset("AZ-360")
    targets = [resolve_target(n, catalog) for n in ("ISS (ZARYA)", "UOSAT 2 (UO-11)")]
    start_s = utc(2026, 8, 23, 2, 5, 15).timestamp()
    clock = LockstepClock(datetime.fromtimestamp(start_s, timezone.utc), parties=2)
    ctrl = AzAzController(spec, spec, clock)
    bench = Bench(ctrl)
    shared = SharedAzAz(partial(open_driver, bench.url, "gs232b-azaz", clock=clock,
                                **driver_limits(spec)))
    followers = [PassFollower(t, partial(shared.axis, n), spec, STATION, clock, antenna=n,
                              first=next_pass(t, STATION, start_s))
                 for n, t in zip((1, 2), targets, strict=True)]
    ctrl.jam("el")                      # antenna 2 lives on the elevation channel
    try:
        with pytest.raises(TrackerError, match=r"^antenna 2 \(UOSAT 2 \(UO-11\)\): .*both "
                                               r"antennas stopped"):
            with ControllerSession(shared.session_stop, stop_at_end=False):
                follow_together(followers, shared)
    finally:
        for f in followers:
            f.close()
        shared.close()
        bench.close()
    assert ctrl.log[-1][1].strip() == b"S"
    assert clock.timestamp() < followers[0].first.los.timestamp()   # ended at the stall


# The example ---------------------------------------------------------------------------------


def test_follow_passes_example_runs(capsys):
    module = runpy.run_path(str(REPO / "examples" / "follow_passes.py"), run_name="example")
    assert module["main"]([]) == 0
    out = capsys.readouterr().out
    assert "pass 1: ISS (ZARYA) 2026-08-23 02:09:11 UTC" in out
    assert "pass 2: ISS (ZARYA) 2026-08-23 03:44:28 UTC" in out
    assert out.count("park: az 0 el 5") == 2
    assert "pass 2: " in out and "last bytes on the wire: 'S' (all-stop)" in out


def test_error_cause_names_the_unwind_the_rate_and_nothing_when_small():
    import numpy as np

    from tracker.mount import preset
    from tracker.planner import error_cause
    from tracker.skytrack import SkyTrack

    t = np.arange(0.0, 600.0, 1.0)
    az = np.where(t < 300, 90.0, 90.0 + np.minimum((t - 300) * 20.0, 180.0))  # 20 deg/s swing
    track = SkyTrack.from_azel(t + 1.7e9, az, np.full_like(t, 80.0), "X")
    small = np.full_like(t, 1.0)
    big = np.where((t > 300) & (t < 310), 150.0, 1.0)
    g400 = preset("G-400")
    assert error_cause(track, g400, "normal", track.t_s, small) == ""
    assert "unwinds once" in error_cause(track, g400, "unwind", track.t_s, big)
    why = error_cause(track, g400, "normal", track.t_s, big)
    assert why.startswith("max azimuth error 150 deg") and "no elevation axis" in why
    assert "faster than the rotator's" in why


def test_a_pass_joined_under_way_is_caught_up_and_then_followed(catalog):
    """Joined 5 min after AOS with the antenna parked far from the target (the plan is a
    flip: az 73, el 138): the first command turns azimuth too (moving only the quicker
    elevation would never end the catch-up), and once there the antenna stays within the
    deadband."""
    noaa = resolve_target("NOAA 20", catalog)
    spec = preset("G-5500")
    pas = next_pass(noaa, STATION, utc(2026, 8, 22, 12, 50).timestamp())
    joined_s = pas.aos.timestamp() + 300.0
    clock = manual_clock(joined_s)
    rig = virtual_rig(make_controller("gs232b", clock, rotator="G-5500", az_deg=0.0,
                                      el_deg=0.0))
    rec = Recorder(clock)
    try:
        (res,) = follow_passes(
            noaa, lambda: open_driver(rig.url, "gs232b", clock=clock, **driver_limits(spec)),
            spec, STATION, clock, SETTINGS, passes=1, first=pas, events=rec)
    finally:
        rig.close()
    first = rec.of("command", cmd="goto", reason="track")[0][1]
    assert first["az_m"] > 30.0                           # azimuth turns toward the target
    caught = [e for t, e in zip(res.error_t_s, res.errors_deg, strict=True)
              if t >= joined_s + 60.0]                    # 210 deg at 6 deg/s, with margin
    assert caught and max(caught) <= SETTINGS.deadband_deg + 1.0, max(caught)
    # The result counts the error from acquisition and says how late and how long it took.
    assert res.max_error_deg <= SETTINGS.deadband_deg + 1.0, res.max_error_deg
    assert max(res.errors_deg) > 90.0                     # the catch-up is still recorded
    assert res.cause.startswith("joined 300 s after AOS; on target "), res.cause
