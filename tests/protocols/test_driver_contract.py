"""One driver contract, run over a real pty and a real TCP socket against the project's
emulators: every GS-232 profile in depth (tables, modes, manual moves, pacing), then every
backend (Rotor-EZ, DCU-1, SAK-232, both AZ/AZ antennas, rotctld in front of the GS-232B
emulator) through the common driver API; and against real hardware when TRACKER_TEST_PORT is
set."""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import pytest
from _gs232_helpers import SPEED, advance_until, wait_until
from _rigs import GS232_PROFILES, ROTCTLD, EmulatedRig, start_rotctld, stop_process

from tracker.clock import SystemClock
from tracker.errors import LimitError, PortLostError, RotatorTimeout
from tracker.protocols import open_driver


@pytest.fixture(params=GS232_PROFILES)
def rig(request, emulated_rig) -> EmulatedRig:
    return emulated_rig(request.param)


def test_position_at_park(rig):
    with rig.driver() as d:
        assert d.position() == (0.0, 0.0)
        assert rig.tail_is(b"C2")


def test_read_back_lags_the_command(rig):
    with rig.driver() as d:
        d.goto(400, 0)
        az, _ = d.position()
        assert rig.seen(b"W400 000")      # the move was received, so the lag is the motor's
        assert 0.0 <= az < 400.0          # the motor model's rate shows on the wire
        assert wait_until(lambda: rig.ctrl.antenna()[0] > az, 5)   # and it is moving there


def test_stop_one_axis(rig):
    with rig.driver() as d:
        d.goto(440, 170)
        assert wait_until(lambda: rig.ctrl.antenna()[1] > 5, 5)
        d.stop_axis("el")
        el1 = d.position()[1]
        assert wait_until(lambda: rig.ctrl.antenna()[0] > 100, 5)
        az2, el2 = d.position()        # whole degrees: 100.4 reads back as 100
        assert el2 == el1 and az2 >= 100
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
        d.position()                        # answered, so everything sent before it has arrived
        assert rig.lines()[before:] == [b"C2"], rig.lines()[before:]


def test_controller_off_and_jam(rig):
    with rig.driver() as d:
        rig.ctrl.set_rotator_power(False)
        assert d.position() == (-1.0, -2.0)
        rig.ctrl.set_rotator_power(True)
        rig.ctrl.jam("az")
        d.goto(200, 20)
        assert wait_until(lambda: rig.ctrl.antenna()[1] == 20.0, 5)
        assert d.position() == (0.0, 20.0)


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
        d.position()                        # answered, so everything sent before it has arrived
        assert r.lines()[before:] == [b"C2"], r.lines()[before:]
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


# Every backend through the common driver API ---------------------------------------------


@dataclass(frozen=True)
class Backend:
    """How one backend meets the common contract against its emulator."""

    protocol: str                 # open_driver's protocol
    emulator: str                 # the controller behind it (make_controller's name)
    target: tuple                 # a goto inside the limits ...
    sent: bytes                   # ... the line the controller receives for it ...
    at_target: Callable           # ... and ctrl -> whether the antenna is there
    far: tuple                    # a long move, to be stopped half-way
    stop_line: bytes              # the line an all-stop arrives as
    out_of_range: tuple           # a goto the driver refuses before sending
    speed: float = SPEED
    closed_loop: bool = True      # reads the position back (else: an open-loop estimate)
    driver_kw: Callable = lambda ctrl: {}
    ctrl_kw: dict = field(default_factory=dict)
    via_rotctld: bool = False     # Hamlib rotctld -m 603 between the driver and the emulator
    az_of: Callable = lambda ctrl: ctrl.antenna()[0]     # the driven antenna's azimuth
    starts: bytes = b""           # the line that starts the motor, when not ``sent`` itself


def _gs232(profile: str) -> Backend:
    return Backend(profile, profile, (270, 30), b"W270 030",
                   lambda c: c.antenna() == (270.0, 30.0), (450, 180), b"S", (451, 0))


BACKENDS = [
    *(_gs232(p) for p in GS232_PROFILES),
    Backend("rotorez", "rotorez", (90,), b"AP1090\r", lambda c: c.antenna() == 90.0, (300,),
            b";", (361,), speed=100.0, az_of=lambda c: c.antenna()),
    # open loop: the driver's estimate runs on the emulator's clock and motor model; at a
    # lower speed so the command latency stays well under a degree
    Backend("dcu1", "dcu1", (45,), b"AP1045;", lambda c: c.antenna() == 45.0, (300,),
            b"AS1;", (361,), speed=20.0, closed_loop=False,
            driver_kw=lambda c: {"start_az_deg": 0.0, "rate_deg_s": c.spec.az_rate_deg_s},
            ctrl_kw={"az_deg": 0.0}, az_of=lambda c: c.antenna(), starts=b"AM1;"),
    Backend("sak232", "sak232", (30,), b"A 30\r",
            lambda c: not c.moving() and abs(c.antenna() - 30) < 0.5, (300,), b"S\r", (400,),
            speed=20.0, closed_loop=False,
            driver_kw=lambda c: {"rate_deg_s": c.spec.az_rate_deg_s, "start_az_deg": 0.0},
            ctrl_kw={"az_deg": 0.0}, az_of=lambda c: c.antenna()),
    Backend("gs232b-azaz", "gs232b-azaz", (120,), b"M120",
            lambda c: c.antenna()[0] == 120.0, (350,), b"S", (361,)),
    Backend("gs232b-azaz2", "gs232b-azaz", (200,), b"MB200",
            lambda c: c.antenna()[1] == 200.0, (350,), b"E", (361,),
            driver_kw=lambda c: {"has_elevation": False, "az_max_deg": 360.0,
                                 "el_max_deg": 90.0}, az_of=lambda c: c.antenna()[1]),
    *(Backend(p, p, (120, 30), b"AZ120.0 EL30.0", lambda c: c.antenna() == (120.0, 30.0),
              (350, 170), b"SA SE ", (361, 0)) for p in ("easycomm2", "easycomm3")),
    # rotctld paces its GS-232B backend in real time (50 ms a write): a slower antenna
    Backend("rotctld", "gs232b", (180, 45), b"W180 045",
            lambda c: c.antenna() == (180.0, 45.0), (20, 170), b"S", (10, 181), speed=20.0,
            via_rotctld=True, driver_kw=lambda c: {"timeout_s": 5.0}),
]


class BackendBench:
    """A backend's emulator on this test's transport, and (for rotctld) the daemon."""

    def __init__(self, backend: Backend, rig: EmulatedRig):
        self.backend, self.rig, self.ctrl = backend, rig, rig.ctrl
        self.daemon = None
        self.url = rig.url
        if backend.via_rotctld:
            if ROTCTLD is None:
                pytest.skip("Hamlib rotctld not installed")
            self.daemon, port = start_rotctld("-m", "603", "-r",
                                              rig.url.removeprefix("socket://"))
            self.url = f"rotctld://127.0.0.1:{port}"

    def driver(self):
        kw = {"timeout_s": 0.5, "clock": self.rig.clock, **self.backend.driver_kw(self.ctrl)}
        if self.backend.via_rotctld:
            kw.pop("clock")
        return open_driver(self.url, self.backend.protocol, **kw)

    def lose_the_port(self) -> None:
        if self.daemon is not None:
            stop_process(self.daemon)
        elif self.rig.transport == "tcp":
            self.rig.server.drop_connections()
        else:
            self.rig.server.hangup()

    def close(self) -> None:
        if self.daemon is not None:
            stop_process(self.daemon)


@pytest.fixture(params=BACKENDS, ids=[b.protocol for b in BACKENDS])
def bench(request, emulated_rig):
    backend = request.param
    b = BackendBench(backend, emulated_rig(backend.emulator, backend.speed, **backend.ctrl_kw))
    yield b
    b.close()


def test_backend_goto_arrives_and_reads_back(bench):
    be = bench.backend
    with bench.driver() as d:
        d.goto(*be.target)
        assert bench.rig.seen(be.sent), bench.rig.lines()
        assert bench.rig.seen(be.starts or be.sent), bench.rig.lines()
        # the slew is not the subject: once the motor runs, jump the clock to see it sooner
        # (an open-loop driver's estimate runs on the same clock, so it jumps alike)
        assert advance_until(bench.rig.clock, lambda: be.at_target(bench.ctrl)), \
            bench.ctrl.antenna()
        az, el = d.position()
        if be.closed_loop:
            assert (az, el) == (float(be.target[0]),
                                float(be.target[1]) if len(be.target) > 1 else None)
        else:   # the estimate follows the same motor model the emulated antenna runs on
            assert el is None and az == pytest.approx(be.target[0], abs=1.0)


def test_backend_stop_halts_the_move_and_exit_sends_all_stop(bench):
    be = bench.backend
    with bench.driver() as d:
        d.goto(*be.far)
        assert wait_until(bench.ctrl.moving), bench.rig.lines()
        d.stop()
        assert wait_until(lambda: not bench.ctrl.moving()), bench.rig.lines()
        held, read = bench.ctrl.antenna(), d.position()
        t0 = bench.rig.clock.monotonic()
        assert wait_until(lambda: bench.rig.clock.monotonic() - t0 > 5.0)
        assert bench.ctrl.antenna() == held                       # it stays stopped ...
        assert d.position() == read                               # ... and reads back so
        assert abs(be.az_of(bench.ctrl) - be.far[0]) > 1.0, held  # ... short of the target
        assert be.stop_line in bench.rig.lines()
        d.goto(*be.target)
        assert bench.rig.seen(be.sent)
    # every way out ends with the all-stop: the last line the controller received (Hamlib's
    # GS-232B backend ends each command with CR LF, which the emulator logs as a blank line)
    assert wait_until(lambda: [x for x in bench.rig.lines() if x][-1] == be.stop_line), \
        bench.rig.lines()


def test_backend_refuses_out_of_range_before_sending(bench):
    be = bench.backend
    last = be.starts or be.sent            # the goto's last line on the wire
    with bench.driver() as d:
        d.goto(*be.target)                 # a session is open and the wire works
        assert bench.rig.seen(last)
        before = len(bench.rig.lines())
        with pytest.raises(LimitError):
            d.goto(*be.out_of_range)
        with pytest.raises(LimitError):
            d.goto(float("nan"), *be.target[1:])
        # A valid goto after the refusals is the marker: once its lines have arrived, anything
        # the refused calls had sent would have arrived before them.
        d.goto(*be.target)
        assert wait_until(lambda: bench.rig.lines().count(last) == 2), bench.rig.lines()
        d.stop_on_exit = False
    after = [x for x in bench.rig.lines()[before:] if x]   # Hamlib's CR LF logs a blank line
    assert after == [be.sent, be.starts] if be.starts else after == [be.sent], after


def test_backend_port_lost_is_a_typed_error(bench):
    be = bench.backend
    d = bench.driver()
    d.goto(*be.target)
    assert bench.rig.seen(be.sent)
    bench.lose_the_port()
    # a hangup may take an exchange or two to be noticed; then a typed error, never a hang
    # and never anything else
    with pytest.raises((PortLostError, RotatorTimeout)):
        for _ in range(20):
            if be.closed_loop:
                d.position()
            else:
                d.goto(*be.target)
            time.sleep(0.02)
    d.stop_on_exit = False
    d.close()
