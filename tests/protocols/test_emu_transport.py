"""The ``emu://`` transport (an emulated controller in-process, on its clock) and read
timeouts measured on the port's time."""

from __future__ import annotations

import time
from datetime import datetime, timezone

import pytest
import serial
from _virtual import manual_clock, virtual_rig

from tracker.clock import ManualClock, SimClock, SystemClock
from tracker.emulator import Gs232Controller, serve_pty
from tracker.emulator.faults import install
from tracker.errors import PortLostError, RotatorIOError, RotatorTimeout
from tracker.mount import preset
from tracker.protocols import open_driver
from tracker.transport import io_clock, open_port

T0_S = 1787400000.0


def _rig(*faults, **kw):
    clock = manual_clock(T0_S)
    return virtual_rig(Gs232Controller("gs232b", preset("G-5500"), clock, az_deg=123,
                                       el_deg=45, **kw), faults)


def test_emu_url_answers_on_write_and_a_waiting_read_jumps_to_the_timeout():
    rig = _rig()
    try:
        port = open_port(rig.url, timeout_s=0.5, clock=rig.clock)
        assert io_clock(port) is rig.clock
        port.write(b"C2\r")
        assert port.in_waiting > 0                    # answered on write, no thread
        assert port.read(100) == b"AZ=123  EL=045\r\n"
        t0 = rig.clock.monotonic()
        assert port.read(1) == b""                    # nothing due: the whole timeout passes
        assert rig.clock.monotonic() - t0 == pytest.approx(0.5)
        port.close()
    finally:
        rig.close()


def test_a_delayed_reply_arrives_exactly_when_due_on_virtual_time():
    rig = _rig("delay=0.2")
    try:
        port = open_port(rig.url, timeout_s=5.0, clock=rig.clock)
        port.write(b"C2\r")
        t0 = rig.clock.monotonic()
        assert port.read(16) == b"AZ=123  EL=045\r\n"
        assert rig.clock.monotonic() - t0 == pytest.approx(0.2, abs=1e-3)   # not 5 s
    finally:
        rig.close()


def test_motion_is_exact_on_virtual_time_and_costs_no_wall_time():
    rig = _rig()
    try:
        d = open_driver(rig.url, "gs232b", clock=rig.clock)
        d.goto(200, 45)
        wall0 = time.monotonic()
        rig.clock.sleep(600.0)                        # ten simulated minutes
        assert d.position() == (200.0, 45.0)
        assert time.monotonic() - wall0 < 1.0
        assert rig.written().startswith(b"W200 045\r")
        d.close()
    finally:
        rig.close()


def test_unplug_fails_the_open_port_and_new_opens_until_replugged():
    rig = _rig()
    try:
        d = open_driver(rig.url, "gs232b", clock=rig.clock, retries=0)
        assert d.position() == (123.0, 45.0)
        rig.bench.unplug()
        with pytest.raises(PortLostError):
            d.position()
        with pytest.raises(RotatorIOError, match="unplugged"):
            open_driver(rig.url, "gs232b", clock=rig.clock)
        rig.bench.replug()
        d2 = open_driver(rig.url, "gs232b", clock=rig.clock)
        assert d2.position() == (123.0, 45.0)
    finally:
        rig.close()


def test_timed_faults_fire_on_virtual_time_while_a_read_waits():
    # disconnect at t=2 s: a read that waits past it sees the port lost, at that very time
    rig = _rig("disconnect=3@2")
    try:
        port = open_port(rig.url, timeout_s=10.0, clock=rig.clock)
        with pytest.raises(serial.SerialException, match="disconnected"):
            port.read(1)
        assert rig.clock.monotonic() == pytest.approx(2.0, abs=1e-3)
        rig.clock.sleep(3.0)
        assert open_driver(rig.url, "gs232b", clock=rig.clock).position() == (123.0, 45.0)
    finally:
        rig.close()


def test_profile_urls_make_a_controller_and_reopen_finds_the_same_one():
    clock = ManualClock(datetime(2026, 8, 23, tzinfo=timezone.utc))
    url = "emu://gs232b?rotator=G-5500&az=10&el=5"
    d = open_driver(url, "gs232b", clock=clock)
    assert d.position() == (10.0, 5.0)
    d.goto(40, 5)
    d.close()
    clock.sleep(60.0)
    assert open_driver(url, "gs232b", clock=clock).position() == (40.0, 5.0)  # same box


@pytest.mark.parametrize("url, needle", [
    ("emu://nosuch", "no emulator for 'nosuch'"),
    ("emu://gs232b?colour=red", "unknown option 'colour'"),
    ("emu://gs232b?fault=explode=1", "unknown fault"),
])
def test_bad_emu_urls_are_one_clear_error(url, needle):
    with pytest.raises((RotatorIOError, Exception), match=needle):
        open_port(url, clock=ManualClock(datetime(2026, 8, 23, tzinfo=timezone.utc)))


def test_a_bench_refuses_a_second_clock():
    rig = _rig()
    try:
        with pytest.raises(RotatorIOError, match="own clock"):
            open_port(rig.url, clock=manual_clock(T0_S))
    finally:
        rig.close()


def test_real_ports_run_on_real_time():
    assert isinstance(io_clock(serial.serial_for_url("loop://")), SystemClock)


@pytest.mark.parametrize("protocol", ["gs232b", "rotorez"])
def test_read_timeout_is_real_time_even_when_the_simulation_runs_100x(protocol):
    """A 1 s timeout measured on a 100x SimClock was 10 ms of wall time, so a reply 0.2 s
    away on a real pty timed out. The deadline is the port's (real) time now, in the GS-232
    driver and in the byte link the Rotor-EZ, DCU-1, SAK-232 and rotctld drivers share."""
    from tracker.emulator.factory import make_emulator

    clock = SimClock(datetime(2026, 8, 23, tzinfo=timezone.utc), speed=100.0)
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock, az_deg=123, el_deg=45) \
        if protocol == "gs232b" else make_emulator(protocol, clock, az_deg=123)
    expected = (123.0, 45.0) if protocol == "gs232b" else (123.0, None)
    install(ctrl, ["delay=20"])                    # 20 simulated s = 0.2 s of wall time
    server = serve_pty(ctrl)
    try:
        d = open_driver(server.url, protocol, clock=clock, timeout_s=1.0, retries=0)
        d.stop_on_exit = False
        assert d.position() == expected
        d.close()
        d = open_driver(server.url, protocol, clock=clock, timeout_s=0.05, retries=0)
        d.stop_on_exit = False
        t0 = time.monotonic()
        with pytest.raises(RotatorTimeout):
            d.position()
        assert time.monotonic() - t0 >= 0.05
        d.close()
    finally:
        server.close()
