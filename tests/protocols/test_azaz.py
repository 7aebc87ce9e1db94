"""GS-232B-AZ/AZ: the dual-azimuth driver against the emulator over a real pty and TCP
socket: two antennas with two targets, one tracking while the other holds, synced with an
offset; S stops both, the axis views stop one."""

from __future__ import annotations

from datetime import datetime

import pytest
from _gs232_helpers import T0, wait_until

from tracker.clock import ManualClock
from tracker.emulator.azaz_controller import AzAzController
from tracker.errors import LimitError
from tracker.protocols import open_driver
from tracker.protocols.azaz import AzAzDriver  # registers gs232b-azaz, gs232b-azaz2


@pytest.fixture
def served(emulated_rig):
    """(controller, server, clock) on a real pty and a real TCP socket, leak-checked."""
    rig = emulated_rig("gs232b-azaz", 120.0)
    return rig.ctrl, rig.server, rig.clock


def _cmds(ctrl):
    return [line for _t, line, _r in ctrl.log]


def test_two_antennas_two_targets_and_independent_stops(served):
    ctrl, server, clock = served
    with open_driver(server.url, "gs232b-azaz", clock=clock) as drv:
        assert isinstance(drv, AzAzDriver)
        a1, a2 = drv.axis(1), drv.axis(2)
        assert not a1.capabilities.has_elevation and a1.capabilities.has_position_query
        a1.goto(120)
        a2.goto(250)
        assert wait_until(lambda: ctrl.antenna() == (120.0, 250.0), 10), ctrl.antenna()
        assert drv.positions() == (120.0, 250.0)
        assert a1.position() == (120.0, None) and a2.position() == (250.0, None)
        # one tracks while the other holds: stopping antenna 2 leaves antenna 1 running
        a1.goto(0)
        a2.goto(350)
        assert wait_until(lambda: ctrl.antenna()[1] > 260, 5)
        a2.stop()
        assert wait_until(lambda: not ctrl.motor.el.moving(ctrl.clock.monotonic()), 5)
        held2 = ctrl.antenna()[1]
        assert ctrl.motor.az.moving(ctrl.clock.monotonic())
        assert wait_until(lambda: ctrl.antenna()[0] == 0.0, 10)
        assert ctrl.antenna()[1] == held2 and 250 < held2 < 350
        drv.goto_both(45, 300)
        assert wait_until(lambda: ctrl.antenna() == (45.0, 300.0), 10)
        with pytest.raises(LimitError):
            a2.goto(361)
        with pytest.raises(LimitError):
            drv.goto_both(10, -1)
    assert wait_until(lambda: _cmds(ctrl)[-1] == b"S")          # every exit: all-stop
    cmds = _cmds(ctrl)
    assert cmds[:2] == [b"M120", b"MB250"] and b"E" in cmds and b"W045 300" in cmds
    assert b"S" not in cmds[:-1]                       # single-antenna stops never use S
    assert not any(c.startswith((b"MB361", b"W010")) for c in cmds)


def test_synced_with_offset(served):
    ctrl, server, clock = served
    with open_driver(server.url, "gs232b-azaz", clock=clock) as drv:
        drv.sync(90)
        drv.axis(1).goto(100)
        assert wait_until(lambda: ctrl.antenna() == (100.0, 190.0), 10), ctrl.antenna()
        with pytest.raises(LimitError, match="synced"):
            drv.axis(2).goto(10)
        drv.axis(1).goto(300)                       # 300 + 90 wraps to 030
        assert wait_until(lambda: ctrl.antenna() == (300.0, 30.0), 15), ctrl.antenna()
        drv.unsync()
        drv.axis(2).goto(60)
        assert wait_until(lambda: ctrl.antenna() == (300.0, 60.0), 10), ctrl.antenna()
    assert b"Y090" in _cmds(ctrl) and b"Y999" in _cmds(ctrl)


def test_azimuth2_view_for_tracker_track(served):
    ctrl, server, clock = served
    with open_driver(server.url, "gs232b-azaz2", clock=clock, has_elevation=False,
                     az_max_deg=360.0, el_max_deg=90.0) as a2:
        a2.goto(200)
        assert wait_until(lambda: ctrl.antenna()[1] == 200.0, 10)
        assert a2.position() == (200.0, None)
        assert ctrl.antenna()[0] == 0.0                # antenna 1 never moved
    assert wait_until(lambda: _cmds(ctrl)[-1] == b"E")    # exit stops antenna 2 only


def test_emulator_s_stops_option_and_power_cycle_cancels_sync():
    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = AzAzController(clock=clock, s_stops="az2")
    s = ctrl.open_session()
    s.feed(b"W100 100\r")
    clock.advance(5)
    s.feed(b"S\r")
    clock.advance(20)
    az1, az2 = ctrl.antenna()
    assert az1 == 100.0 and 20 < az2 < 30
    s.feed(b"Y\r")
    clock.advance(20)
    assert ctrl.antenna() == (100.0, 100.0)
    ctrl.power_cycle()
    assert ctrl.sync_offset is None
    assert s.feed(b"Y361\r") == b"?>\r\n"


def test_each_antenna_runs_its_own_step_table(served):
    ctrl, server, clock = served
    with open_driver(server.url, "gs232b-azaz", clock=clock) as drv:
        a1, a2 = drv.axis(1), drv.axis(2)
        assert a2.capabilities.has_step_tables
        a1.upload_table(5, [10, 20, 30])
        a2.upload_table(5, [300, 290, 280])
        assert a1.table_status() == (1, 3) and a2.table_status() == (1, 3)
        assert wait_until(lambda: ctrl.antenna() == (10.0, 300.0), 10), ctrl.antenna()
        a2.start_table()                               # only antenna 2 steps
        assert wait_until(lambda: a2.table_status() == (3, 3), 10)
        assert ctrl.antenna()[0] == 10.0 and a1.table_status() == (1, 3)
        assert wait_until(lambda: ctrl.antenna()[1] == 280.0, 10)
        with pytest.raises(LimitError):
            a2.upload_table(5, [(1, 2), (3, 4)])
    cmds = _cmds(ctrl)
    assert b"M005 010 020 030" in cmds and b"MB005 300 290 280" in cmds
    assert b"TB" in cmds and b"T" not in cmds
