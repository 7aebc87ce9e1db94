"""One driver contract, run over a real pty and a real TCP socket against the project's
emulators: every GS-232 profile in depth (tables, modes, manual moves, pacing), then every
backend (Rotor-EZ, DCU-1, SAK-232, both AZ/AZ antennas, rotctld in front of the GS-232B
emulator) through the common driver API; and against real hardware when TRACKER_TEST_PORT is
set."""

from __future__ import annotations

import itertools
import os
import time

import pytest
from _gs232_helpers import wait_until
from _rigs import GS232_PROFILES, EmulatedRig

from tracker.clock import SystemClock
from tracker.errors import LimitError, PortLostError
from tracker.protocols import open_driver


@pytest.fixture(params=GS232_PROFILES)
def rig(request, emulated_rig) -> EmulatedRig:
    return emulated_rig(request.param)


def test_position_at_park(rig):
    with rig.driver() as d:
        assert d.position() == (0.0, 0.0)
        assert rig.tail_is(b"C2")


def test_goto_moves_the_antenna_and_reads_back(rig):
    with rig.driver() as d:
        d.goto(270, 30)
        assert rig.seen(b"W270 030")
        assert wait_until(lambda: rig.ctrl.antenna() == (270.0, 30.0), 5)
        assert d.position() == (270.0, 30.0)


def test_read_back_lags_the_command(rig):
    with rig.driver() as d:
        d.goto(400, 0)
        az, _ = d.position()
        assert rig.seen(b"W400 000")      # the move was received, so the lag is the motor's
        assert 0.0 <= az < 400.0          # the motor model's rate shows on the wire
        assert wait_until(lambda: rig.ctrl.antenna()[0] > az, 5)   # and it is moving there


def test_stop_halts_motion_and_exit_sends_stop(rig):
    with rig.driver() as d:
        d.goto(450, 180)
        assert wait_until(lambda: rig.ctrl.antenna()[0] > 20, 5)
        d.stop()
        p1 = d.position()
        time.sleep(0.2)
        assert d.position() == p1
        assert p1[0] < 450
        d.goto(100, 10)
    assert rig.tail_is(b"S")


def test_stop_one_axis(rig):
    with rig.driver() as d:
        d.goto(440, 170)
        assert wait_until(lambda: rig.ctrl.antenna()[1] > 5, 5)
        d.stop_axis("el")
        el1 = d.position()[1]
        assert wait_until(lambda: rig.ctrl.antenna()[0] > 100, 5)
        az2, el2 = d.position()
        assert el2 == el1 and az2 > 100
        assert rig.seen(b"E")


def test_manual_move_and_speed(rig):
    with rig.driver() as d:
        d.set_speed(2)
        d.move("cw")
        d.move("up")
        assert wait_until(lambda: rig.ctrl.antenna()[0] > 30, 5)
        d.stop()
        assert rig.tail_is(b"X2", b"R", b"U", b"S")


def test_table_upload_and_stepping(rig):
    with rig.driver() as d:
        d.upload_table(1, [(10, 5), (20, 10), (30, 15)])
        assert rig.seen(b"W001 010 005 020 010 030 015")
        assert wait_until(lambda: rig.ctrl.antenna() == (10.0, 5.0), 5)
        cur, total = d.table_status()
        assert total == 3 and cur in (1, None)
        d.start_table()
        assert wait_until(lambda: rig.ctrl.antenna() == (30.0, 15.0), 5)
        if rig.protocol == "k3ng":
            assert rig.ctrl.table is None   # K3NG clears the list at the end
        else:
            assert d.table_status() == (3, 3)


def test_limits_refused_before_sending(rig):
    with rig.driver() as d:
        before = len(rig.ctrl.log)
        for az, el in [(451, 0), (-1, 0), (90, 181), (float("nan"), 0)]:
            with pytest.raises(LimitError):
                d.goto(az, el)
        with pytest.raises(LimitError):
            d.upload_table(0, [1, 2])
        with pytest.raises(LimitError):
            d.set_speed(5)
        assert len(rig.ctrl.log) == before


def test_controller_off_and_jam(rig):
    with rig.driver() as d:
        rig.ctrl.set_rotator_power(False)
        assert d.position() == (-1.0, -2.0)
        rig.ctrl.set_rotator_power(True)
        rig.ctrl.jam("az")
        d.goto(200, 20)
        assert wait_until(lambda: rig.ctrl.antenna()[1] == 20.0, 5)
        assert d.position() == (0.0, 20.0)


def test_port_lost_is_typed(emulated_rig):
    r = emulated_rig("gs232b")
    d = r.driver()
    assert d.position() == (0.0, 0.0)
    if r.transport == "tcp":
        r.server.drop_connections()
    else:
        r.server.hangup()
    t0 = time.monotonic()
    with pytest.raises(PortLostError):
        for _ in range(5):   # a hangup may take one exchange to be noticed
            d.position()
            time.sleep(0.05)
    assert time.monotonic() - t0 < 3
    d.close()


def test_azimuth_only_driver_uses_c_and_m(emulated_rig):
    r = emulated_rig("gs232a")
    with r.driver(has_elevation=False) as d:
        assert d.position() == (0.0, None)
        d.goto(90, 45)
        assert r.tail_is(b"C", b"M090")
        assert wait_until(lambda: r.ctrl.antenna() == (90.0, 0.0), 5)


@pytest.mark.parametrize("profile", ["gs232b", "gs232a"])
def test_help_and_raw(emulated_rig, profile):
    r = emulated_rig(profile)
    with r.driver() as d:
        assert "COMMAND LIST 1" in d.help(1)
        assert "HELP COMMAND 2" in d.help(2)
        assert d.raw("Q") == b"?>\r\n"
        assert d.raw("C2") in (b"AZ=000  EL=000\r\n", b"+0000+0000\r\n")


@pytest.mark.skipif(not os.environ.get("TRACKER_TEST_PORT"),
                    reason="set TRACKER_TEST_PORT=/dev/ttyUSB0 (and TRACKER_TEST_PROTOCOL) "
                           "to run the contract against real hardware")
def test_hardware_position_and_stop():
    with open_driver(os.environ["TRACKER_TEST_PORT"],
                     os.environ.get("TRACKER_TEST_PROTOCOL", "gs232b")) as d:
        az, _el = d.position()
        assert -5 <= az <= 455
        d.stop()


def test_autobaud_handshake(emulated_rig):
    from tracker.emulator import EmulatorOptions
    from tracker.errors import RotatorTimeout

    r = emulated_rig("gs232b", options=EmulatorOptions(autobaud=True))
    with open_driver(r.server.url, "gs232b", timeout_s=0.5, autobaud=True) as d:
        assert d.position() == (0.0, 0.0)
    r.ctrl.faults.deaf = True            # a unit that never says Connect OK
    t0 = time.monotonic()
    with open_driver(r.server.url, "gs232b") as d, \
            pytest.raises(RotatorTimeout, match="Connect OK"):
        d.autobaud(attempts=3, interval_s=0.1)
    assert time.monotonic() - t0 < 2


def test_p36_p45_z_and_help_page_3(emulated_rig):
    r = emulated_rig("gs232b")
    with r.driver() as d:
        d.set_mode_450(False)
        assert r.tail_is(b"P36") and not r.ctrl.mode_450
        # a real GS-232B answers W400 in 360 mode with a ?> nobody reads: the driver
        # refuses it before sending instead of losing the move
        with pytest.raises(LimitError, match=r"0\.\.360"):
            d.goto(400, 0)
        assert "mode 360 Degree\r\nN Center" in d.help(3)
        d.toggle_centre()
        assert r.tail_is(b"Z") and r.ctrl.south_centre
        assert "S Center" in d.help(3)
        d.set_mode_450(True)
        assert r.tail_is(b"P45") and r.ctrl.mode_450
        assert d.capabilities.az_max_deg == 450.0
        d.goto(400, 0)
        assert r.seen(b"W400 000")


def test_b_only_commands_refused_on_gs232a(emulated_rig):
    from tracker.errors import ConfigError

    r = emulated_rig("gs232a")
    with r.driver() as d:
        before = len(r.ctrl.log)
        with pytest.raises(ConfigError, match="GS-232B command"):
            d.set_mode_450(False)
        with pytest.raises(ConfigError, match="GS-232B command"):
            d.toggle_centre()
        assert len(r.ctrl.log) == before
        assert d.help(3) == "?>\r\n"          # the A unit has no third help page


class _RecordingClock(SystemClock):
    """Real time, but remembers every sleep the driver asks for (its pacing)."""

    def __init__(self):
        super().__init__()
        self.sleeps: list[float] = []

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        super().sleep(seconds)


@pytest.mark.parametrize(("profile", "rtscts"), [("gs232b", True), ("gs232a", False),
                                                 ("k3ng", False)])
def test_rtscts_for_gs232b_paced_writes_without_handshake(emulated_rig, profile, rtscts):
    r = emulated_rig(profile)
    clock = _RecordingClock()
    with r.driver(clock=clock) as d:
        assert d.port.rtscts is rtscts
        writes: list[float] = []
        real_write = d.port.write

        def write(data):
            writes.append(clock.monotonic())
            return real_write(data)
        d.port.write = write
        d.set_speed(2)
        d.stop()
        d.goto(10, 10)
        d.position()
        assert len(writes) == 4
        gaps = [b - a for a, b in itertools.pairwise(writes)]
        if rtscts:        # flow control paces the line: the driver never waits itself
            assert d.pace_cmd_s == 0 and clock.sleeps == []
        else:             # measured on the driver's own clock, a lower bound only
            assert d.pace_cmd_s > 0
            assert all(g >= d.pace_cmd_s for g in gaps), gaps


@pytest.mark.parametrize(("kw", "message"), [({"timeout_s": float("nan")}, "timeout_s"),
                                             ({"timeout_s": 0}, "timeout_s"),
                                             ({"ack_timeout_s": float("inf")}, "ack_timeout"),
                                             ({"retries": -1}, "retries")])
def test_invalid_timing_is_refused_and_the_port_released(emulated_rig, kw, message):
    from tracker.errors import ConfigError

    r = emulated_rig("gs232b")
    with pytest.raises(ConfigError, match=message):
        open_driver(r.server.url, "gs232b", **kw)
    # the port opened for it was closed again: the next client gets a clean session
    with r.driver() as d:
        assert d.position() == (0.0, 0.0)
    if r.transport == "tcp":
        assert wait_until(lambda: r.server.connections == 0, 2)


def test_full_size_tables_cross_the_real_port(emulated_rig):
    # 3800 angles / 1900 pairs are ~15.2 kB on one line: the pty and socket paths must carry
    # it whole (the emulator accepts lines of at least 16 kB)
    r = emulated_rig("gs232b")
    with r.driver(timeout_s=2.0) as d:
        d.upload_table(5, [i % 451 for i in range(3800)])
        assert d.table_status() == (1, 3800)
        d.upload_table(5, [(i % 451, i % 181) for i in range(1900)])
        assert d.table_status() == (1, 1900)
        with pytest.raises(LimitError, match="3801 table points"):
            d.upload_table(5, list(range(3801)))
    assert max(len(line) for line in r.lines()) == len("M005") + 4 * 3800
