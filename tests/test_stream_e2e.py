"""The live loop end to end against the GS-232B emulator.

One whole pass per real transport (a pty and a TCP socket, emulator and loop on one fast
SimClock) shows the loop works over the wire. The scenarios (unplug, dropped connection,
jam, control box off, a crash) run on the virtual tier: the emulator behind ``emu://`` and
the loop on one ManualClock, so they take CPU time only and their bounds are exact.
"""

from __future__ import annotations

import time
from datetime import datetime, timezone

import numpy as np
import pytest
from _stream_fakes import T0, arc_pass
from _virtual import manual_clock, virtual_rig

from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_pty, serve_tcp
from tracker.errors import StallError
from tracker.mount import preset
from tracker.planner import plan_pass
from tracker.protocols import open_driver
from tracker.skytrack import angular_separation_deg
from tracker.station import HorizonMask, Station
from tracker.stream import Link, StreamSettings, TrackCore, run_pass

SPEC = preset("G-5500", 50)
# Real I/O runs the emulator and the loop on a SimClock tied to wall time, so scheduling
# jitter becomes simulated lag in proportion to the speed: a moderate speed, and a margin.
SPEED = 20.0
REAL_IO_SLACK_DEG = 2.0
REAL_IO_LOST_DEG = 20.0   # beyond this the antenna was not following at all
DEADBAND = 3.0


class Bench:
    """Emulator + loop on one clock; ``faults`` maps seconds after AOS to callbacks.
    ``transport``: "tcp" or "pty" (real I/O, SimClock) or "emu" (virtual time)."""

    def __init__(self, transport="emu", faults=None, duration_s=150.0, station=None):
        self.track = arc_pass(duration_s=duration_s, pad_s=20.0)
        self.station = station or Station()
        self.plan = plan_pass(self.track, SPEC, self.station, current=(95.0, 0.0))
        start = min(self.plan.preposition_t_s, T0 - 25.0) - 2.0
        self.clock = manual_clock(start) if transport == "emu" else \
            SimClock(datetime.fromtimestamp(start, timezone.utc), SPEED)
        self.ctl = Gs232Controller("gs232b", SPEC, clock=self.clock, az_deg=95.0, el_deg=0.0)
        self.transport = transport
        self.server = {"tcp": serve_tcp, "pty": serve_pty, "emu": virtual_rig}[transport](
            self.ctl)
        self.servers = [self.server]
        self.core = TrackCore(self.plan, self.track, SPEC, self.station,
                              StreamSettings(deadband_deg=DEADBAND))
        self.faults = dict(faults or {})
        self.errors: list[tuple[float, float]] = []
        self.events: list[tuple[float, str, dict]] = []

    def connect(self):
        return open_driver(self.server.url, "gs232b", timeout_s=0.5, clock=self.clock)

    def on_status(self, st):
        az, el = self.ctl.antenna()
        if self.core.aos_s <= st.t_s <= self.core.los_s:
            taz, tel = self.track.direction_at(st.t_s)
            self.errors.append((st.t_s, float(angular_separation_deg(
                SPEC.bearing_of(az), el, taz, tel))))
        self._fire(st.t_s)

    def _fire(self, t_s):
        for t_off in sorted(self.faults):
            if t_s >= T0 + t_off:
                self.faults.pop(t_off)(self)

    def event(self, kind, **data):
        self.events.append((self.clock.timestamp(), kind, data))
        if data.get("state") in ("reconnecting", "no_reply"):
            self._fire(self.clock.timestamp())   # time passes while the port is gone

    def run(self):
        try:
            return run_pass(self.core, Link(self.connect, SPEC), self.clock,
                            on_status=self.on_status, events=self.event)
        finally:
            # The last command is written without an ack: over real I/O, let the emulator
            # read it first (emu:// answers on write).
            deadline = time.monotonic() + 2.0
            while self.transport != "emu" and time.monotonic() < deadline and (
                    not self.ctl.log or self.ctl.log[-1][1].strip() != b"S"):
                time.sleep(0.01)
            for s in self.servers:
                s.close()

    def states(self):
        return [d.get("state") for _t, k, d in self.events if k == "state"]

    def last_line(self):
        return self.ctl.log[-1][1].strip()


@pytest.mark.parametrize("transport", ["tcp", "pty", "emu"])
def test_pass_completes_within_plan_prediction_plus_deadband(transport):
    b = Bench(transport)
    res = b.run()
    assert res.completed
    err = np.array([e for _t, e in b.errors])
    assert len(err) > 100
    # measured at the emulator's antenna (float), against the true target direction
    bound = b.plan.max_error_deg + DEADBAND
    if transport == "emu":
        assert err.max() <= bound, err.max()   # virtual time: exact, no jitter
    else:
        # Real I/O on a SimClock: a scheduling hiccup of the loaded machine is simulated lag
        # (36 ms at 20x is 0.7 s of slewing), so a sample may spike; nearly all of them stay
        # inside the bound, and none is lost.
        inside = float(np.mean(err <= bound + REAL_IO_SLACK_DEG))
        assert inside >= 0.95 and err.max() <= REAL_IO_LOST_DEG, (inside, err.max())
    gotos = [d for _t, k, d in b.events if k == "command" and d.get("cmd") == "goto"]
    assert res.commands == len(gotos) and 5 <= res.commands <= 120
    print(f"\n{transport}: {res.commands} commands, max error {err.max():.2f} deg "
          f"(plan {b.plan.max_error_deg:.2f} + deadband {DEADBAND})")


def test_unplugged_mid_pass_reconnects_and_resumes():
    def unplug(b):
        b.server.bench.unplug()                # the device vanishes (USB unplug)
        b.unplug_t = b.clock.timestamp()

    def replug(b):
        b.server.bench.replug()                # and comes back 8 s later
        b.replug_t = b.clock.timestamp()
    b = Bench(faults={40: unplug, 48: replug})
    res = b.run()
    assert res.completed and res.reconnects >= 1
    assert "port_lost" in b.states() and "reconnected" in b.states()
    back = next(t for t, _k, d in b.events if d.get("state") == "reconnected")
    assert b.unplug_t < b.replug_t <= back
    after = np.array([e for t, e in b.errors if t > back + 10.0])
    assert len(after) > 20 and after.max() <= b.plan.max_error_deg + DEADBAND, after.max()


def test_connection_dropped_mid_pass_reconnects_and_resumes():
    def drop(b):
        b.server.bench.drop_connections()
    b = Bench(faults={60: drop})
    res = b.run()
    assert res.completed and res.reconnects >= 1
    assert "reconnected" in b.states()
    late = np.array([e for t, e in b.errors if t > T0 + 80])
    assert late.max() <= b.plan.max_error_deg + DEADBAND, late.max()


def test_jammed_axis_all_stop_within_3_s_simulated():
    def jam(b):
        b.ctl.jam("el")
        b.jam_t = b.ctl.clock.monotonic()
    b = Bench(faults={20: jam})
    with pytest.raises(StallError, match="elevation did not move"):
        b.run()
    t_last, line, _reply = b.ctl.log[-1]
    assert line.strip() == b"S" and b.server.written().endswith(b"S\r")
    # A jammed axis at rest harms nothing until it is told to move: count from then.
    moves = [t for t, ln, _r in b.ctl.log if ln.startswith(b"W") and t >= b.jam_t]
    told = max(b.jam_t, moves[0]) if moves else b.jam_t
    assert t_last - told <= 3.0, (t_last, b.jam_t, moves)


def test_controller_off_no_blind_moves_then_resumes():
    def off(b):
        b.ctl.set_rotator_power(False)
        b.off_t = b.ctl.clock.monotonic()

    def on(b):
        b.ctl.set_rotator_power(True)
        b.on_t = b.ctl.clock.monotonic()
    b = Bench(faults={30: off, 45: on})
    res = b.run()
    assert res.completed
    assert "controller_off" in b.states()
    sent_while_off = [line.strip()[:1] for t, line, _r in b.ctl.log
                      if b.off_t < t < b.on_t and not line.strip().startswith(b"C")]
    assert set(sent_while_off) <= {b"S"}


def test_connection_dropped_while_parking_resumes_the_move_under_way():
    """The park under a horizon mask is a sequence (up, across, down). A reconnect in the
    middle re-sends the move under way; going back to the first move would turn the antenna
    back across the sky to where the pass ended."""
    mask = HorizonMask((0.0, 90.0, 180.0, 270.0), (4.0, 8.0, 6.0, 3.0))

    def drop(b):
        b.drop_t = b.ctl.clock.monotonic()
        b.server.bench.drop_connections()
    b = Bench(station=Station(mask=mask))
    first_az = b.plan.park_moves[0].az_deg
    assert len(b.plan.park_moves) >= 2 and abs(first_az - b.plan.park_moves[1].az_deg) > 90
    # the across move takes ~50 s from the LOS azimuth to park: drop the link half way
    b.faults = {b.core.los_s - T0 + 20.0: drop}
    res = b.run()
    assert res.completed and "reconnected" in b.states()
    after = [ln.strip() for t, ln, _r in b.ctl.log if t > b.drop_t and ln.startswith(b"W")]
    assert after, "nothing was commanded after the reconnect"
    # every move after the drop heads for the park azimuth, none back to the LOS azimuth
    assert all(abs(int(ln[1:].split()[0]) - b.plan.park_moves[-1].az_deg) <= 1
               for ln in after), after
    az, _el = b.ctl.antenna()
    assert abs(az - b.plan.park_moves[-1].az_deg) <= 1.0


def test_any_exception_mid_pass_sends_all_stop_last():
    """A bug anywhere in the loop (here: the status sink raises) still leaves the antenna
    stopped: S is the last line the controller received, while it was turning."""
    def boom(b):
        if not b.ctl.moving():   # wait for the next tracking move
            b.faults[b.clock.timestamp() - T0 + 0.01] = boom
            return
        b.hit_t = b.clock.timestamp()
        raise RuntimeError("UI crashed")
    b = Bench(faults={10.0: boom})
    with pytest.raises(RuntimeError, match="UI crashed"):
        b.run()
    assert b.hit_t < b.core.los_s
    assert b.last_line() == b"S"
    assert b.server.written().endswith(b"S\r")     # the very last bytes on the wire
    assert not b.ctl.moving()
