"""Line noise is not a stall, and erratic read-back ends the run: a lost command is re-sent
before an axis is judged stalled, and well-formed but random read-back is reported instead
of being followed for ever.

On virtual time through the GS-232B emulator behind ``emu://`` (the bench of
test_faults_stream.py): the noise is drawn from a seed, so every run sees the same bytes
lost or doubled, and every bound on simulated time is exact.
"""

from __future__ import annotations

import random
from datetime import datetime, timezone

import numpy as np
import pytest
from _stream_fakes import T0
from _virtual import manual_clock, virtual_rig
from test_faults_stream import SPEC, STATION, FaultBench, _stop_latency

from tracker.cli import main
from tracker.clock import ManualClock
from tracker.emulator import Gs232Controller
from tracker.errors import ReadbackError, StallError
from tracker.mount import AxisMotor, preset
from tracker.protocols import open_driver
from tracker.stall import AxisWatch
from tracker.stream import Link, StreamSettings, TrackCore, run_pass


def _commands(b) -> list[bytes]:
    return [ln.strip() for _t, ln, _r in b.ctl.log if ln.startswith(b"W")]


def _noisy_pass(noise: str, seed: int) -> tuple[bool, FaultBench]:
    """One pass through ``noise`` in both directions; True if it was (falsely) stopped."""
    b = FaultBench([noise], seed=seed)
    try:
        res = b.run()
    except StallError:
        return True, b
    assert res.completed, (noise, b.states())
    # what the loop sent (the controller's log holds the garbled copies too)
    gotos = [d for _t, k, d in b.events if k == "command" and d.get("cmd") == "goto"]
    assert gotos and all(0 <= d["az"] <= SPEC.az_span_deg
                         and SPEC.el_min_deg <= d["el"] <= SPEC.el_max_deg for d in gotos)
    return False, b


# 20 seeded passes per kind of noise: the same bytes are hit on every run, so the counts are
# exact. Before re-sends every pass with 2 % noise was stopped as a stall.
NOISE_SEEDS = range(20)


@pytest.mark.parametrize("noise", ["drop=0.02", "duplicate=0.02", "garble=0.005"])
def test_line_noise_both_ways_is_not_a_stall(noise):
    """2 % of the bytes lost or doubled (0.5 % garbled) in both directions: every pass
    completes, and copies of lost commands went out."""
    stopped = [seed for seed in NOISE_SEEDS if _noisy_pass(noise, seed)[0]]
    assert stopped == [], stopped
    _stopped, b = _noisy_pass(noise, 0)
    assert any(d.get("resend") for _t, k, d in b.events if k == "command")


def test_heavy_garbling_stops_few_passes():
    """2 % of the bytes turned into other bytes: a W is hit one time in six, and a garbled
    byte can also switch the controller into a mode that ignores moves, which a stop is right
    for. At most 4 of the 20 seeded passes are stopped (every one of them was, before)."""
    stopped = [seed for seed in NOISE_SEEDS if _noisy_pass("garble=0.02", seed)[0]]
    assert len(stopped) <= 4, stopped


def _rig_losing_the_first_command(settings=None):
    from test_stream import Rig

    rig = Rig(start_az=0.0, settings=settings)
    fake, real_goto, lost = rig.fake, rig.fake.goto, []

    def goto(az_deg, el_deg=None):
        if not lost:               # the pre-position W is lost on the line
            lost.append(f"W{az_deg:03.0f} {el_deg:03.0f}")
            fake.written.append(lost[0] + " lost")
            return
        real_goto(az_deg, el_deg)
    fake.goto = goto
    return rig, lost


def test_a_lost_command_is_re_sent_and_the_pass_goes_on():
    rig, lost = _rig_losing_the_first_command()
    res = rig.run()
    assert res.completed and "stall" not in rig.states()
    assert rig.fake.written[:2] == [lost[0] + " lost", lost[0]]     # the same W, again
    copies = [d for _t, k, d in rig.events if k == "command" and d.get("resend")]
    assert 1 <= len(copies) <= 2 and copies[0]["reason"] == "preposition"


def test_without_re_sends_the_lost_command_was_a_false_stall():
    """What the re-send fixes (the behaviour before it)."""
    rig, _lost = _rig_losing_the_first_command(StreamSettings(deadband_deg=3.0,
                                                              stall_resends=0))
    with pytest.raises(StallError):
        rig.run()


def test_jam_is_still_stopped_within_3_s_and_says_what_was_seen():
    b = FaultBench(["jam=az@0"], start_az=300.0)
    with pytest.raises(StallError) as exc:
        b.run()
    msg = str(exc.value)
    assert "azimuth did not move: it stayed at" in msg and "command" in msg
    assert "Possible causes" in msg
    latency = _stop_latency(b, b.inj.t0)
    assert latency <= 3.0, latency
    # the jam was given its copies before the verdict: the same W went out three times
    cmds = _commands(b)
    assert len(cmds) >= 3 and cmds[-1] == cmds[-2] == cmds[-3], cmds[-4:]


def _watch_after_command(target_deg: float, at_deg: float = 218.0) -> AxisWatch:
    watch = AxisWatch()
    axis = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, at_deg, 0.0)
    axis.command(target_deg, 0.0)
    watch.start(axis, 0.0, at_deg)
    return watch


def test_zero_travel_command_is_never_a_stall():
    watch = _watch_after_command(218.0)
    for t in np.arange(0.5, 30.0, 0.5):
        assert watch.check(float(t), 218.0, 1.0, 2.0) is None


def test_fast_rotator_back_at_its_target_between_read_backs_is_not_a_stall():
    """Seen through rotctld: a rotator faster than its model went out and came back between
    two read-backs; the belief still had travel to do. At the target is not a stall."""
    watch = AxisWatch()
    axis = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, 200.0, 0.0)
    axis.command(240.0, 0.0)
    watch.start(axis, 0.0, 200.0)
    axis.command(218.0, 1.0)
    watch.start(axis, 1.0, 200.0)          # read-back had not moved yet: carried travel
    for t in np.arange(1.5, 10.0, 0.5):
        assert watch.check(float(t), 218.0, 1.0, 2.0) is None


# Erratic read-back ---------------------------------------------------------------------------


class ErraticController(Gs232Controller):
    """Answers C2 with random, well-formed positions: a noisy potentiometer."""

    def __init__(self, *a, seed: int = 3, **kw):
        super().__init__(*a, **kw)
        self._rng = random.Random(seed)

    def _readback(self, t):
        return float(self._rng.randint(0, 450)), float(self._rng.randint(0, 180))


def test_erratic_read_back_ends_the_pass_with_all_stop():
    from _stream_fakes import arc_pass

    from tracker.planner import plan_pass

    track = arc_pass(duration_s=150.0, pad_s=20.0)
    plan = plan_pass(track, SPEC, STATION, current=(95.0, 5.0))
    start = min(plan.preposition_t_s, T0 - 25.0) - 2.0
    clock = manual_clock(start)
    ctl = ErraticController("gs232b", SPEC, clock=clock, az_deg=95.0, el_deg=5.0)
    server = virtual_rig(ctl)
    settings = StreamSettings(deadband_deg=3.0, inconsistent_give_up_s=20.0)
    core = TrackCore(plan, track, SPEC, STATION, settings)
    events = []
    try:
        with pytest.raises(ReadbackError, match="read-back is inconsistent"):
            run_pass(core, Link(lambda: open_driver(server.url, "gs232b", timeout_s=0.06,
                                                    clock=clock), SPEC), clock,
                     events=lambda kind, **d: events.append((clock.timestamp(), kind, d)))
    finally:
        server.close()
    assert ctl.log[-1][1].strip() == b"S"
    # ended within the bound of the first contradiction, well before the pass would end
    first = next(t for t, k, d in events if d.get("state") == "contradiction")
    last = events[-1][0]
    assert last - first <= 20.0 + 3.0, (first, last)
    assert last < core.los_s


def test_track_cli_erratic_read_back_is_one_line_exit_2_and_stop_last(tmp_path, capsys,
                                                                       monkeypatch):
    cfg = tmp_path / "empty.toml"
    cfg.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(cfg))
    clock = ManualClock(datetime(2026, 8, 23, 2, 5, tzinfo=timezone.utc))
    ctl = ErraticController("gs232b", preset("G-5500"), clock=clock)
    server = virtual_rig(ctl)
    try:
        rc = main(["track", "ISS (ZARYA)", "--port", server.url, "--at",
                   "2026-08-23T02:05:00Z", "--plain", "--passes", "1"])
    finally:
        server.close()
    err = capsys.readouterr().err
    assert rc == 2
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("tracker: error:")]
    assert len(lines) == 1 and "controller read-back is inconsistent" in lines[0], err
    assert ctl.log[-1][1].strip() == b"S"


def test_contradiction_clock_restarts_when_read_back_agrees_again():
    """A hand turn or a recalibration is a short contradiction: it must not end the run."""
    from _stream_fakes import arc_pass, simple_plan

    track = arc_pass(duration_s=300, pad_s=30)
    core = TrackCore(simple_plan(track, SPEC), track, SPEC, STATION,
                     StreamSettings(deadband_deg=3.0, inconsistent_give_up_s=10.0))
    clock = ManualClock(datetime.fromtimestamp(T0 - 60, timezone.utc))
    t = clock.timestamp()
    core.observe(t, 100.0, 10.0)
    for k in range(30):                      # 15 s: contradictions, then agreement, ...
        az = 300.0 if k % 10 < 5 else 100.0
        core.observe(t + 0.5 * k, az + (k % 2) * 40.0 if k % 10 < 5 else az, 10.0)
    with pytest.raises(ReadbackError):
        for k in range(60):
            core.observe(t + 20.0 + 0.5 * k, float(k * 37 % 360), 10.0)


def test_a_turn_through_the_overlap_that_starts_late_is_not_an_early_arrival():
    """0 -> 360 on a 450 deg rotator: a reading of 0 also names 360, the target. A motor that
    starts a second later than believed must not be taken as already there (the loop would
    then believe 450+ and lose the antenna for the whole slew)."""
    from _stream_fakes import arc_pass, simple_plan

    from tracker.stream import Command

    spec = preset("G-5500", mains_hz=50)
    track = arc_pass(duration_s=300, pad_s=30)
    core = TrackCore(simple_plan(track, spec), track, spec, STATION,
                     StreamSettings(deadband_deg=3.0))
    t0 = T0 - 200.0
    assert core.observe(t0, 0.0, 0.0) == "ok"
    core.commanded(t0, Command(360.0, 0.0, "preposition"))
    late_s = 1.5                               # the real start, after the believed 0.5 s
    seen = []
    for k in range(1, 120):                    # 60 s of the 70 s turn
        t = t0 + 0.5 * k
        az = float(round(max(0.0, t - t0 - late_s) * spec.az_rate_deg_s))
        seen.append(core.observe(t, az, 0.0))
        assert abs(core.antenna[0] - az) < 1.0, (k, az, core.antenna, core.note)
    assert set(seen) == {"ok"}, seen


def test_a_rotator_still_slewing_after_a_contradiction_is_trusted_again():
    """After a jump the loop waits for read-backs that agree; a rotator on a long slew moves
    between readings at its rate, which agrees. It must not be called inconsistent."""
    from _stream_fakes import arc_pass, simple_plan

    spec = preset("G-5500", mains_hz=50)
    track = arc_pass(duration_s=300, pad_s=30)
    core = TrackCore(simple_plan(track, spec), track, spec, STATION,
                     StreamSettings(deadband_deg=3.0, inconsistent_give_up_s=10.0))
    t0 = T0 - 200.0
    core.observe(t0, 100.0, 10.0)
    assert core.observe(t0 + 0.5, 200.0, 10.0) == "contradiction"    # turned by hand
    results = [core.observe(t0 + 0.5 * k, 200.0 + 2.5 * (k - 1), 10.0) for k in range(2, 80)]
    assert results[0] == "contradiction"         # one agreeing step is not yet enough
    assert set(results[1:]) == {"ok"}, results
    # Readings that jump further than the rotator can turn stay untrusted, and end the run.
    with pytest.raises(ReadbackError):
        for k in range(60):
            core.observe(t0 + 60.0 + 0.5 * k, float(k * 37 % 360), 10.0)


def test_watch_on_target_as_before_is_the_same_as_restarting_it():
    """A read-back still on the target of an axis at rest (most cycles) leaves the watch as
    the general path (motion seen or on target: restart the expectation) would."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        pos = float(rng.integers(0, 450))
        axis = AxisMotor(0.0, 450.0, 5.0, 0.5, 1.0, pos, 0.0)
        t = float(rng.uniform(1.0, 50.0))
        quick, general = AxisWatch(), AxisWatch()
        for w in (quick, general):
            w.start(axis, 0.0, pos)          # asked for no travel: on target
            w.check(0.5, pos, 1.0, 2.0)      # settles on it (the general path)
        assert quick.expect.rests_on(pos) and quick.ref_pos_deg == pos
        assert quick.check(t, pos, 1.0, 2.0) is None
        general._moved(t, pos, seen=False)
        expect_q, expect_g = quick.__dict__.pop("expect"), general.__dict__.pop("expect")
        assert quick.__dict__ == general.__dict__
        for dt in (0.0, 1.0, 30.0):
            assert expect_q.position(t + dt) == expect_g.position(t + dt)
            assert expect_q.moving(t + dt) == expect_g.moving(t + dt)
        assert expect_q.target_deg == expect_g.target_deg
        quick.expect, general.expect = expect_q, expect_g
        assert quick.motion_overdue(t + 1.0, 1.0) == general.motion_overdue(t + 1.0, 1.0)
