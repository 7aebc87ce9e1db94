"""SAK-232: the open-loop driver against the emulator over a real pty and TCP socket, and
the emulator's documented choices (K limit search, gear ratio, options)."""

from __future__ import annotations

from datetime import datetime

import pytest
from _gs232_helpers import T0, advance_until, wait_until

from tracker.clock import ManualClock
from tracker.emulator.sak232_controller import ZELPRO_RAU, Sak232Controller, Sak232Options
from tracker.errors import LimitError
from tracker.mount import RotatorSpec
from tracker.protocols import open_driver
from tracker.protocols import sak232 as codec
from tracker.protocols.sak232 import check_gear, encode_azimuth  # registers "sak232"


def test_codec_limits():
    assert [encode_azimuth(v) for v in (0, 90.4, 359.4, 359.5, 360)] == [0, 90, 359, 0, 0]
    for bad in (-1, 360.5, "x"):
        with pytest.raises(LimitError):
            encode_azimuth(bad)
    check_gear(5, 3)
    check_gear(24, 1)
    for p, d in ((25, 1), (5, 25), (2, 3), (0, 1), (1000, 24)):
        with pytest.raises(LimitError):
            check_gear(p, d)


def test_commands_decode_to_what_the_driver_encoded():
    import typing

    sent = [codec.GotoAz(0), codec.GotoAz(359), codec.MoveRelative(-359),
            codec.MoveRelative(999), codec.Orient(12), codec.FindLimits(),
            codec.SetGear(24, 1), codec.Stop(), codec.Gs23Goto(5), codec.Gs23Position()]
    for msg in sent:
        assert codec.decode_command(codec.encode(msg)) == msg, msg
    assert codec.encode(codec.MoveRelative(-5)) == b"R -5"
    assert codec.encode(codec.SetGear(6, 4)) == b"P 6 4"
    for line in (b"A 360", b"a 10", b"R 1000", b"P 25 1", b"S 1", b"M0900", b"M360", b"",
                 b"A x", b"\xff"):
        assert codec.decode_command(line) == codec.Invalid(line), line
    assert codec.decode_command(b"  A   7 ") == codec.GotoAz(7)
    with pytest.raises(ValueError):
        codec.encode(codec.Invalid(b"x"))
    assert set(Sak232Controller()._handlers) == set(typing.get_args(codec.Command))


def test_driver_moves_the_antenna_and_estimate_follows(emulated_rig):
    rig = emulated_rig("sak232", 20.0)
    ctrl, server, clock = rig.ctrl, rig.server, rig.clock
    with open_driver(server.url, "sak232", clock=clock,
                     rate_deg_s=ZELPRO_RAU.az_rate_deg_s) as drv:
        assert not drv.capabilities.has_position_query
        drv.goto(90)
        # once the controller has the command, the slew is seen sooner by jumping the shared
        # clock: the driver's estimate and the emulated motor both run on it
        assert wait_until(lambda: len(ctrl.log) == 1)
        assert advance_until(clock, lambda: not ctrl.moving()
                             and abs(ctrl.antenna() - 90) < 0.5)
        assert drv.position()[0] == pytest.approx(ctrl.antenna(), abs=1.0)
        drv.move_relative(-45)
        assert wait_until(lambda: len(ctrl.log) == 2)
        assert advance_until(clock, lambda: not ctrl.moving()
                             and abs(ctrl.antenna() - 45) < 0.5)
        assert drv.position()[0] == pytest.approx(45.0, abs=1.0)
        drv.orient(200)                   # calibrate: this heading is 200
        assert wait_until(lambda: ctrl.antenna() == pytest.approx(200.0), 5)
        assert drv.position()[0] == 200.0
        drv.set_gear(5, 3)
        assert wait_until(lambda: ctrl.gear == (5, 3), 5)
        drv.goto(300)
        assert wait_until(ctrl.moving, 5)
        drv.stop()
        assert wait_until(lambda: not ctrl.moving(), 5)
        with pytest.raises(LimitError):
            drv.goto(400)
    assert wait_until(lambda: len(ctrl.log) == 7)
    cmds = [c for _t, c, _r in ctrl.log]
    assert cmds == [b"A 90\r", b"R -45\r", b"O 200\r", b"P 5 3\r", b"A 300\r", b"S\r",
                    b"S\r"]


def _make(**opts):
    clock = ManualClock(datetime.fromisoformat(T0))
    spec = RotatorSpec(name="test", az_span_deg=360, stop_bearing_deg=0, el_max_deg=None,
                       el_rate_deg_s=None, az_rate_deg_s=10.0, start_delay_s=0.0)
    ctrl = Sak232Controller(spec, clock, Sak232Options(**opts), az_deg=100)
    return ctrl, ctrl.open_session(), clock


def test_k_runs_to_both_hard_limits_and_stores_them():
    ctrl, s, clock = _make()
    assert s.feed(b"K\r") == b""
    clock.advance(5)
    assert ctrl.antenna() == pytest.approx(50.0)          # running CCW first
    clock.advance(5)
    assert ctrl.antenna() == pytest.approx(0.0)
    assert ctrl.k_phase == 2                              # then CW
    clock.advance(36)
    assert ctrl.antenna() == pytest.approx(0.0)           # 360 = north again
    assert ctrl.k_phase == 0 and ctrl.soft == (0.0, 360.0) and not ctrl.moving()


def test_s_interrupts_k_and_relative_is_clipped():
    ctrl, s, clock = _make()
    s.feed(b"K\r")
    clock.advance(2)
    s.feed(b"S\r")
    clock.advance(20)
    assert ctrl.antenna() == pytest.approx(80.0) and ctrl.k_phase == 0
    s.feed(b"R 999\r")
    clock.advance(60)
    assert ctrl.antenna() == pytest.approx(0.0)           # the CW limit (360 = north)
    assert ctrl.motor.az.position(clock.monotonic()) == pytest.approx(360.0)


def test_options_echo_ack_error_and_lf():
    _, s, _ = _make(echo=True, ack=b"OK\r\n", error=b"?\r\n", lf_is_enter=True)
    assert s.feed(b"A 10\n") == b"A 10\nOK\r\n"
    assert s.feed(b"a 10\r") == b"a 10\r?\r\n"
    _, s, _ = _make()
    assert s.feed(b"A 10\r\n") == b""                    # default: silent, LF ignored
    assert s.feed(b"C\r") == b""                          # no query without gs23


def test_gear_ratio_sets_the_motor_step():
    ctrl, s, clock = _make()
    s.feed(b"P 5 3\r")
    assert ctrl.motor.az.resolution_deg == pytest.approx(0.6)
    s.feed(b"A 151\r")
    clock.advance(30)
    assert ctrl.antenna() == pytest.approx(151.2)         # nearest 0.6 deg step
