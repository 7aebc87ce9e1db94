"""Scripted fault injection: the spec parser, reproducibility, and every fault against the
GS-232 driver: typed errors within the timeout, never a hang. The faults run on virtual time
(the emulator behind ``emu://`` on a ManualClock, bounds measured on the port's time); the
port vanishing runs over a real pty and a real TCP socket too, as it is the OS's error."""

from __future__ import annotations

import time
from datetime import datetime

import pytest
from _gs232_helpers import T0, wait_until
from _virtual import virtual_rig

from tracker.cli import main
from tracker.clock import ManualClock, SimClock
from tracker.emulator import EmulatorOptions, Gs232Controller, serve_pty, serve_tcp
from tracker.emulator.faults import EXAMPLES, FaultPlan, install, parse_fault
from tracker.errors import ConfigError, PortLostError, ProtocolError, RotatorIOError, RotatorTimeout
from tracker.mount import preset
from tracker.protocols import open_driver
from tracker.transport import io_clock

TIMEOUT_S = 0.3
RETRIES = 1
BOUND_S = (1 + RETRIES) * TIMEOUT_S + 1.0     # the longest any driver call may take


# Parser ------------------------------------------------------------------------------------


def test_every_documented_example_parses():
    kinds = {parse_fault(e).kind for e in EXAMPLES}
    assert kinds == {"drop", "garble", "duplicate", "delay", "silent", "deaf", "powercycle",
                     "jam", "drift", "wrongside", "disconnect"}
    assert parse_fault("silent=30@120").end_s == 150.0
    assert parse_fault("drift=0.5%").value == pytest.approx(0.005)
    assert parse_fault("drift=-200ppm").value == pytest.approx(-0.0002)
    j = parse_fault("jam=el:30@60")
    assert (j.axis, j.value, j.start_s, j.end_s) == ("el", 30.0, 60.0, 90.0)
    assert parse_fault("jam=az@60").end_s is None
    assert parse_fault("garble=0.1:out").direction == "out"
    assert parse_fault("powercycle@300").value == 1.0


@pytest.mark.parametrize("bad, why", [
    ("bogus", "unknown fault 'bogus'"), ("drop", "needs a probability"),
    ("drop=1.5", "must be in 0..1"), ("drop=0.1:sideways", "direction"),
    ("silent@5", "needs a duration"), ("jam=x@1", "axis 'x'"), ("delay=abc", "not a number"),
    ("wrongside=3", "takes no value"), ("silent=5@", "cannot read"), ("drift=nan%", "must be"),
])
def test_bad_specs_name_the_problem_and_show_the_syntax(bad, why):
    with pytest.raises(ConfigError, match=why) as ei:
        parse_fault(bad)
    assert "NAME[=VALUE][@START_S]" in str(ei.value)


def test_cli_rejects_a_bad_fault_with_exit_2(capsys):
    assert main(["emulate", "--tcp", "0", "--fault", "jam=up@3", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: fault 'jam=up@3'") and "Traceback" not in err


def test_emulate_help_documents_every_fault_and_the_syntax(capsys):
    from tracker.emulator.faults import ALL_KINDS

    with pytest.raises(SystemExit):
        main(["emulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "NAME[=VALUE][@START_S]" in text and "@100+30" in text
    for kind in ALL_KINDS:
        assert kind in text, kind
    for example in ("drop=0.01", "silent=30@120", "powercycle=2@300", "jam=el:30@60",
                    "drift=0.5%", "drift=-200ppm", "disconnect=5@200", ":in or :out"):
        assert example in text, example
        if "=" in example:
            parse_fault(example)     # every example in the help parses


# Controller level (exact, ManualClock) ---------------------------------------------------


def make(specs, seed=0, profile="gs232b", spec=None, **opts):
    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = Gs232Controller(profile, spec or preset("G-5500"), clock, EmulatorOptions(**opts),
                           az_deg=123, el_deg=45)
    inj = install(ctrl, specs, seed)
    return ctrl, ctrl.open_session(), clock, inj


def _replies(seed, n=200):
    _, s, _, inj = make(["garble=0.05:out", "drop=0.05:out", "duplicate=0.05:out"], seed)
    return b"".join(s.feed(b"C2\r") for _ in range(n)), inj


def test_same_seed_same_faults_other_seed_other_faults():
    a, inj = _replies(7)
    assert a == _replies(7)[0]
    assert a != _replies(8)[0]
    clean = b"AZ=123  EL=045\r\n" * 200
    assert a != clean
    n = 200 * len(b"AZ=123  EL=045\r\n")
    # each rate close to 5 % of the bytes (binomial, 3200 trials: sd ~ 12)
    for k in ("bytes_dropped", "bytes_garbled", "bytes_duplicated"):
        assert 0.03 * n < inj.stats[k] < 0.07 * n, (k, inj.stats)


def test_input_direction_faults_hit_commands_not_replies():
    _, s, _, inj = make(["drop=1:in"])
    assert s.feed(b"C2\r") == b""                           # the CR never arrived
    assert inj.stats["bytes_dropped"] == 3
    _, s, _, _ = make(["drop=1:out"])
    assert s.feed(b"C2\r") == b""
    _, s, _, _ = make(["duplicate=1:in"])
    assert s.feed(b"C2\r") == b"?>\r\n?>\r\n"               # CC22 and the empty line


def test_delay_holds_replies_on_the_emulator_clock():
    _, s, clock, inj = make(["delay=0.5"])
    assert s.feed(b"C2\r") == b""
    clock.advance(0.4)
    assert s.poll() == b""
    clock.advance(0.1)
    assert s.poll() == b"AZ=123  EL=045\r\n"
    assert inj.stats["replies_delayed"] == 1


def test_silent_and_deaf_windows_open_and_close_on_time():
    ctrl, s, clock, _ = make(["silent=10@5", "deaf=5@20"])
    assert s.feed(b"C2\r") != b""
    clock.advance(5)
    assert s.feed(b"M100\r") == b"" and s.feed(b"C2\r") == b""   # acts, does not answer
    assert ctrl.motor.az.target_deg == 100.0
    clock.advance(10)
    assert s.feed(b"C2\r").startswith(b"AZ=")                   # t=15: talking again
    clock.advance(5)
    assert s.feed(b"M200\r") == b"" and s.feed(b"C2\r") == b""  # t=20: deaf
    assert ctrl.motor.az.target_deg == 100.0                    # M200 never heard
    clock.advance(5)
    assert s.feed(b"C2\r").startswith(b"AZ=")                   # t=25: hears again


def test_powercycle_loses_the_table_and_needs_autobaud_again():
    ctrl, s, clock, inj = make(["powercycle=2@10"], autobaud=True)
    assert s.feed(b"\r\r") == b"Connect OK\r\n"
    s.feed(b"M005 100 110 120 130\r")
    s.feed(b"T\r")
    clock.advance(10)
    assert s.feed(b"N\r") == b""                                 # off for 2 s
    clock.advance(2)
    assert s.feed(b"N\r") == b""                                 # on again: autobaud first
    assert s.feed(b"\r\r") == b"Connect OK\r\n"
    assert s.feed(b"N\r") == b"?>\r\n"                           # the table is gone
    held = ctrl.antenna()
    clock.advance(30)
    assert ctrl.antenna() == held                                # motors stopped
    assert inj.stats["powercycle_events"] == 1


def test_jam_stalls_an_axis_for_its_duration():
    ctrl, s, clock, _ = make(["jam=az:20@5"])
    clock.advance(5)
    s.feed(b"W200 045\r")
    clock.advance(15)
    assert ctrl.antenna()[0] == pytest.approx(123.0)
    clock.advance(5)                                             # unjammed at t=25
    s.feed(b"W200 045\r")
    clock.advance(20)
    assert ctrl.antenna()[0] == pytest.approx(200.0)


def test_drift_stretches_the_step_clock():
    _ctrl, s, clock, _ = make(["drift=2%"])
    s.feed(b"M010 " + b" ".join(b"%03d" % a for a in range(100, 200, 5)) + b"\r")
    clock.advance(60)
    s.feed(b"T\r")
    clock.advance(100.0)          # nominal: 10 steps, point 12; 2 % slow: 9 steps (10.2 s)
    assert s.feed(b"N\r") == b"+0011+0020\r\n"
    clock.advance(2.0)            # 102 s = 10 drifted periods
    assert s.feed(b"N\r") == b"+0012+0020\r\n"
    _ctrl2, s2, clock2, _ = make([])
    s2.feed(b"M010 100 105 110 115\r")
    s2.feed(b"T\r")
    clock2.advance(10.0)
    assert s2.feed(b"N\r") == b"+0003+0004\r\n"


def test_wrongside_reports_0_359_in_450_mode():
    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock, az_deg=400, el_deg=10)
    s = ctrl.open_session()
    assert s.feed(b"C2\r") == b"AZ=400  EL=010\r\n"
    install(ctrl, ["wrongside"])
    assert s.feed(b"C2\r") == b"AZ=040  EL=010\r\n"


def test_drift_and_wrongside_with_a_start_time_begin_then():
    """``drift=10%@30`` / ``wrongside@40`` were once parsed and then applied from t=0."""
    _ctrl, s, clock, _ = make(["drift=10%@30"])
    s.feed(b"M010 " + b" ".join(b"%03d" % a for a in range(100, 200, 5)) + b"\r")
    s.feed(b"T\r")
    clock.advance(29.0)           # T: point 2; steps at 10 and 20 (drifted: 11, 22)
    assert s.feed(b"N\r") == b"+0004+0020\r\n"
    clock.advance(1.0)            # the step due at 30 is still on the nominal clock
    assert s.feed(b"N\r") == b"+0005+0020\r\n"
    clock.advance(10.5)           # nominal: a step at 40; 10 % slow from 30: at 41
    assert s.feed(b"N\r") == b"+0005+0020\r\n"
    clock.advance(1.0)
    assert s.feed(b"N\r") == b"+0006+0020\r\n"

    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock, az_deg=400, el_deg=10)
    s = ctrl.open_session()
    install(ctrl, ["wrongside@40"])
    clock.advance(39.0)
    assert s.feed(b"C2\r") == b"AZ=400  EL=010\r\n"
    clock.advance(1.5)
    assert s.feed(b"C2\r") == b"AZ=040  EL=010\r\n"


# With the driver: on virtual time, and the port vanishing over a real pty / TCP ------------


class Bench:
    """``kind``: "emu" (virtual time: a ManualClock, the emulator behind emu://) or "tcp" /
    "pty" (real I/O, the emulator on a real-time SimClock)."""

    def __init__(self, kind, specs, tmp_path, seed=1, az_deg=123, **opts):
        start = datetime.fromisoformat(T0)
        self.kind = kind
        self.clock = ManualClock(start) if kind == "emu" else SimClock(start, speed=1.0)
        self.ctrl = Gs232Controller("gs232b", preset("G-5500"), self.clock,
                                    EmulatorOptions(**opts), az_deg=az_deg, el_deg=45)
        if kind == "emu":
            self.server = virtual_rig(self.ctrl, specs, seed)
            self.inj = self.server.injector
        else:
            self.inj = install(self.ctrl, specs, seed)
            self.server = serve_tcp(self.ctrl) if kind == "tcp" else serve_pty(
                self.ctrl, link=str(tmp_path / "ttyEMU0"))
        self.url = self.server.url
        self.drivers = []

    def driver(self, **kw):
        kw.setdefault("timeout_s", TIMEOUT_S)
        kw.setdefault("retries", RETRIES)
        d = open_driver(self.url, "gs232b", clock=self.clock, **kw)
        d.stop_on_exit = False
        self.drivers.append(d)
        return d

    def wait_emulator(self, t_s: float) -> None:
        """Let the emulator's clock pass ``t_s`` s after the faults were installed (virtual
        time: a jump; real I/O: a bounded wait)."""
        if self.kind == "emu":
            self.clock.sleep(t_s - self.inj.elapsed_s() + 1e-3)
        else:
            assert wait_until(lambda: self.inj.elapsed_s() > t_s, t_s + 3.0)

    def close(self):
        for d in self.drivers:
            d.close()
        self.server.close()
        if self.kind != "emu":
            assert self.server.closed and not self.server.thread.is_alive()


def _bench_factory(kind, tmp_path):
    made = []

    def factory(specs, **kw):
        b = Bench(kind, specs, tmp_path, **kw)
        made.append(b)
        return b
    factory.kind = kind
    return factory, made


@pytest.fixture
def bench(tmp_path):
    factory, made = _bench_factory("emu", tmp_path)
    yield factory
    for b in made:
        b.close()


@pytest.fixture(params=["emu", "tcp", "pty"])
def wire_bench(request, tmp_path):
    factory, made = _bench_factory(request.param, tmp_path)
    yield factory
    for b in made:
        b.close()


def bounded(fn, *args):
    """Call ``fn``; return (result or the typed exception, seconds of the port's time).
    Anything else fails."""
    drv = fn.__self__
    clock = io_clock(drv.port if hasattr(drv, "port") else drv.link.port)
    t0 = clock.monotonic()
    try:
        out = fn(*args)
    except (RotatorTimeout, ProtocolError, PortLostError) as e:
        out = e
    elapsed = clock.monotonic() - t0
    assert elapsed < BOUND_S, f"{fn.__name__} took {elapsed:.2f} s"
    return out, elapsed


def test_total_reply_loss_is_a_timeout_within_the_bound(bench):
    d = bench(["drop=1:out"]).driver()
    out, _ = bounded(d.position)
    assert isinstance(out, RotatorTimeout)


@pytest.mark.parametrize("spec", ["drop=0.04", "garble=0.04", "duplicate=0.04"])
def test_line_noise_gives_readings_or_typed_errors_never_a_hang(bench, spec):
    b = bench([spec])
    d = b.driver(timeout_s=0.15)
    outcomes = [bounded(d.position)[0] for _ in range(15)]
    good = [o for o in outcomes if isinstance(o, tuple)]
    errors = [o for o in outcomes if isinstance(o, Exception)]
    assert good and errors, (spec, outcomes)     # noise did hit, and retries still got through
    assert good.count((123.0, 45.0)) >= len(good) // 2


def test_delay_below_the_timeout_only_adds_latency(bench):
    b = bench(["delay=0.2"])
    d = b.driver(timeout_s=1.0)
    out, elapsed = bounded(d.position)
    assert out == (123.0, 45.0) and elapsed >= 0.2


def test_delay_beyond_the_timeout_is_a_timeout(bench):
    d = bench(["delay=1.5"]).driver(retries=0)
    out, _ = bounded(d.position)
    assert isinstance(out, RotatorTimeout)


def test_replies_held_for_a_client_that_left_are_dropped_with_it(tmp_path):
    # Over a long unattended run clients come and go: what was held back for one must not
    # pile up, nor reach the next client.
    b = Bench("emu", ["delay=5"], tmp_path)
    try:
        d = b.driver(retries=0)
        out, _ = bounded(d.position)
        assert isinstance(out, RotatorTimeout)
        assert b.inj.next_release_in_s() is not None      # the reply is still held
        d.close()
        assert b.inj.next_release_in_s() is None
    finally:
        b.close()


def test_silent_window_times_out_then_recovers(bench):
    b = bench(["silent=1.0@0"])
    d = b.driver()
    out, _ = bounded(d.position)
    assert isinstance(out, RotatorTimeout)
    b.wait_emulator(1.05)
    assert bounded(d.position)[0] == (123.0, 45.0)


def test_powercycle_over_the_wire_table_lost_autobaud_recovers(bench):
    b = bench(["powercycle=0.3@1.5"], autobaud=True)
    d = b.driver()
    d.autobaud(attempts=5, interval_s=0.1)
    d.upload_table(5, [130, 140, 150])
    assert d.table_status() == (1, 3)
    assert b.inj.elapsed_s() < 1.5
    b.wait_emulator(1.9)
    out, _ = bounded(d.table_status)
    assert isinstance(out, RotatorTimeout)          # needs autobaud again: no answers
    d.autobaud(attempts=5, interval_s=0.1)
    out, _ = bounded(d.table_status)
    assert isinstance(out, ProtocolError) and out.raw == b"?>"   # the table is gone


def test_jam_over_the_wire_the_antenna_does_not_move(bench):
    b = bench(["jam=az@0"])
    d = b.driver()
    d.goto(200, 45)
    assert b"W200 045" in [c for _t, c, _r in b.ctrl.log]   # the controller has the move
    b.clock.sleep(10.0)                              # ~60 deg if free
    assert d.position() == (123.0, 45.0)


def test_wrongside_over_the_wire(bench):
    d = bench(["wrongside"], az_deg=400).driver()
    assert d.position() == (40.0, 45.0)


def test_drift_over_the_wire(bench):
    b = bench(["drift=10%"])
    d = b.driver()
    d.upload_table(1, list(range(100, 160, 2)))
    d.start_table()
    t0 = b.clock.monotonic()
    b.clock.sleep(11.5)
    cur, total = d.table_status()
    elapsed = b.clock.monotonic() - t0
    assert total == 30 and elapsed == pytest.approx(11.5)
    # nominal point = 2 + floor(11.5 / 1.0) = 13; drifted = 2 + floor(11.5 / 1.1) = 12
    assert cur == 2 + int(elapsed / 1.1) == 12
    assert cur < 2 + int(elapsed / 1.0)


def test_disconnect_typed_error_then_reopen_and_resume(wire_bench):
    b = wire_bench(["disconnect=0.8@0.4"])
    now = (lambda: b.clock.monotonic()) if b.kind == "emu" else time.monotonic
    pause = b.clock.sleep if b.kind == "emu" else time.sleep
    d = b.driver()
    assert d.position() == (123.0, 45.0)
    err = None
    t_end = now() + 3.0
    while now() < t_end:
        out, _ = bounded(d.position)
        if isinstance(out, Exception):
            err = out
            break
        pause(0.02)
    assert isinstance(err, (PortLostError, RotatorTimeout)), err
    d.close()
    # the port is back at t=1.2 s: reopen until it answers, within 3 s of its return
    b.wait_emulator(1.2)
    back = now()
    while True:
        try:
            d2 = b.driver()
            if bounded(d2.position)[0] == (123.0, 45.0):
                break
        except RotatorIOError:
            pass
        assert now() - back < 3.0, "did not resume within 3 s"
        pause(0.05)
    assert b.inj.stats["disconnect_events"] == 1


def test_every_fault_at_once_never_hangs(bench):
    b = bench(["drop=0.02", "garble=0.02", "duplicate=0.02", "delay=0.05", "silent=0.3@0.5",
               "powercycle=0.2@1.2", "jam=el@0", "drift=1%", "wrongside"], seed=3)
    d = b.driver()
    kinds = set()
    t_end = b.clock.monotonic() + 2.0
    while b.clock.monotonic() < t_end:
        out, _ = bounded(d.position)
        kinds.add(type(out).__name__)
        try:
            d.goto(150, 30)
        except (RotatorIOError, ProtocolError):
            kinds.add("goto-error")
    assert "tuple" in kinds and kinds & {"RotatorTimeout", "ProtocolError"}


def test_plan_from_cli_strings_round_trip():
    plan = FaultPlan.parse(["disconnect=5@200", "drop=0.01"], seed=4)
    assert plan.needs_reopen and plan.seed == 4 and len(plan.of("drop")) == 1


def test_byte_controllers_get_wire_faults_through_the_server():
    """Rotor-EZ sessions do not run the injector themselves: the server applies it."""
    from tracker.emulator.rotorez_controller import RotorEzController

    clock = SimClock(datetime.fromisoformat(T0), speed=1.0)
    ctrl = RotorEzController(clock=clock)
    inj = install(ctrl, ["drop=1:out", "jam=az@0", "powercycle@0.1"])
    server = serve_tcp(ctrl)
    try:
        d = open_driver(server.url, "rotorez", timeout_s=0.2, retries=0)
        d.stop_on_exit = False
        out, _ = bounded(d.position)
        assert isinstance(out, RotatorTimeout)
        assert inj.stats["bytes_dropped"] > 0 and inj.stats["jam_events"] == 1
        assert wait_until(lambda: inj.stats["powercycle_events"] == 1, 2)
        d.close()
    finally:
        server.close()
    assert not server.errors


def test_rate_fault_window_opens_and_closes():
    _, s, clock, inj = make(["drop=1:out@10+5"])
    assert s.feed(b"C2\r") == b"AZ=123  EL=045\r\n"
    clock.advance(10)
    assert s.feed(b"C2\r") == b""
    clock.advance(5)
    assert s.feed(b"C2\r") == b"AZ=123  EL=045\r\n"
    assert inj.stats["bytes_dropped"] == 16
    with pytest.raises(ConfigError, match="@START\\+DURATION is for rate"):
        parse_fault("silent=5@1+2")


def test_el_jam_on_an_azimuth_only_rotator_is_counted_not_fatal():
    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = Gs232Controller("gs232b", preset("G-1000DXA"), clock)
    inj = install(ctrl, ["jam=el@1"])
    s = ctrl.open_session()
    clock.advance(2)
    assert s.feed(b"C\r") == b"AZ=000\r\n"
    assert inj.stats["not_applicable"] == 1


@pytest.mark.slow
def test_cli_emulate_with_faults_end_to_end(emulate, capsys):
    """``tracker emulate --fault ...`` in one process, ``tracker rotator`` in this one: the
    silent window is a one-line error with exit 2, then the port answers again; a pty with a
    disconnect fault is served behind a stable link that comes back."""
    # Windows of seconds, not fractions: they run on the emulator's real clock from its
    # start, and a loaded machine can take a second to get to the first query.
    p = emulate("--pty", "--fault", "silent=4@0", "--fault", "disconnect=3@8",
                "--fault-seed", "3")
    url = p.url
    assert url.endswith("/ttyEMU0"), url               # the stable link, not /dev/pts/N
    args = ["rotator", "--port", url, "--timeout", "0.2", "position"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: no reply to C2") and "Traceback" not in err
    assert wait_until(lambda: main(args) == 0, 8)          # silent window over at t=4 s
    assert wait_until(lambda: main(args) == 2, 8)          # unplugged at t=8 s
    assert wait_until(lambda: main(args) == 0, 8)          # back at t=11 s, same path
    capsys.readouterr()
    rc, out, _ = p.stop()
    assert rc == 0
    assert "faults: " in out and "silent_events 1" in out and "disconnect_events 1" in out


@pytest.mark.slow
def test_cli_emulate_tcp_with_faults_end_to_end(emulate, capsys):
    """``tracker emulate --protocol gs232b --tcp 0 --fault ...``: the port closes for the
    disconnect window (a one-line error, exit 2), then listens again on the same port; a jam
    keeps the antenna where it is although a move was commanded."""
    p = emulate("--protocol", "gs232b", "--tcp", "0", "--fault", "jam=az@0",
                "--fault", "disconnect=3@6")   # seconds of margin on a loaded machine
    url = p.url
    assert url.startswith("socket://127.0.0.1:"), url
    pos = ["rotator", "--port", url, "--timeout", "0.3", "position"]
    assert main(["rotator", "--port", url, "--timeout", "0.3", "goto", "200", "10"]) == 0
    assert wait_until(lambda: main(pos) == 2, 8)           # port closed at t=6 s
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: ") and "Traceback" not in err
    assert wait_until(lambda: main(pos) == 0, 8)           # listening again, same port
    az, el = (float(v) for v in capsys.readouterr().out.split()[-2:])
    assert az == 0 and el > 0, (az, el)     # azimuth jammed; elevation obeyed the goto
    rc, out, _ = p.stop()
    assert rc == 0
    assert "jam_events 1" in out and "disconnect_events 1" in out
