"""The emulated controller: long form limits, modes, options, dialogues, faults, servers."""

from __future__ import annotations

import socket
from datetime import datetime

import pytest
from _gs232_helpers import T0, wait_until

from tracker.clock import ManualClock
from tracker.emulator import EmulatorOptions, Gs232Controller, serve_tcp
from tracker.mount import preset


def make(profile="gs232b", spec=None, **opts):
    clock = ManualClock(datetime.fromisoformat(T0))
    ctrl = Gs232Controller(profile, spec or preset("G-5500"), clock, EmulatorOptions(**opts))
    return ctrl, ctrl.open_session(), clock


def test_read_back_shows_motor_lag():
    ctrl, s, clock = make()
    s.feed(b"W360 090\r")
    clock.advance(10.0)
    az, el = ctrl.antenna()
    rate = preset("G-5500").az_rate_deg_s
    assert az == pytest.approx((10.0 - 0.5) * rate)      # 0.5 s start delay
    assert s.feed(b"C2\r") == b"AZ=%03d  EL=%03d\r\n" % (round(az), round(el))


def test_long_form_limits_and_16k_lines():
    _ctrl, s, _ = make()
    line = b"M001 " + b" ".join(b"%03d" % (i % 451) for i in range(3800)) + b"\r"
    assert len(line) > 15000
    assert s.feed(line) == b""
    assert s.feed(b"N\r") == b"+0001+3800\r\n"
    assert s.feed(line[:-1] + b" 001\r") == b"?>\r\n"           # 3801 angles
    assert s.feed(b"N\r") == b"?>\r\n"                           # and the list is cleared
    pairs = b"W001 " + b" ".join(b"100 020" for _ in range(1900)) + b"\r"
    assert s.feed(pairs) == b""
    assert s.feed(b"N\r") == b"+0001+1900\r\n"
    assert s.feed(pairs[:-1] + b" 100 020\r") == b"?>\r\n"
    assert s.feed(b"M005 090\r") == b"?>\r\n"                     # fewer than 2 angles
    assert s.feed(b"M000 090 100\r") == b"?>\r\n"                 # interval 000
    assert s.feed(b"M005 090 451\r") == b"?>\r\n"                 # angle out of range
    padded = b"M001  " + b"  ".join(b"%03d" % (i % 451) for i in range(3800)) + b"\r"
    assert len(padded) > 16 * 1024                                # a line over 16 kB
    assert s.feed(padded) == b"" and s.feed(b"N\r") == b"+0001+3800\r\n"


def test_stepping_follows_the_clock_and_stays_on_last_point():
    ctrl, s, clock = make()
    s.feed(b"M020 010 020 030 040\r")
    clock.advance(30)
    s.feed(b"T\r")
    statuses = []
    for _ in range(5):
        statuses.append(s.feed(b"N\r"))
        clock.advance(20)
    assert statuses == [b"+0002+0004\r\n", b"+0003+0004\r\n", b"+0004+0004\r\n",
                        b"+0004+0004\r\n", b"+0004+0004\r\n"]
    assert ctrl.antenna()[0] == 40.0


def test_end_behaviour_clear_option_and_stop_cancels_stepping():
    ctrl, s, clock = make(end_behaviour="clear")
    s.feed(b"M001 010 020 030\r")
    s.feed(b"T\r")
    clock.advance(5)
    assert s.feed(b"N\r") == b"?>\r\n"
    s.feed(b"M005 010 020 030\r")
    clock.advance(30)
    s.feed(b"T\r")
    clock.advance(2)
    s.feed(b"S\r")
    held = ctrl.antenna()
    clock.advance(60)
    assert ctrl.antenna() == held and 10.0 < held[0] < 20.0


def test_speed_steps_change_the_azimuth_rate():
    spec = preset("G-5500").with_(az_speed_rates_deg_s=(1.0, 2.0, 3.0, 4.0), start_delay_s=0)
    ctrl, s, clock = make(spec=spec)
    s.feed(b"X1\r")
    s.feed(b"M400\r")
    clock.advance(10)
    assert ctrl.antenna()[0] == pytest.approx(10.0)
    s.feed(b"X4\r")                      # takes effect during rotation
    clock.advance(10)
    assert ctrl.antenna()[0] == pytest.approx(50.0)


def test_modes_450_360_centre_and_readback_options():
    ctrl, s, clock = make()
    s.feed(b"M400\r")
    clock.advance(200)
    assert s.feed(b"C\r") == b"AZ=400\r\n"
    assert s.feed(b"Z\r") == b""                  # ignored in 450 mode
    assert not ctrl.south_centre
    s.feed(b"P36\r")
    assert s.feed(b"M400\r") == b"?>\r\n"
    s.feed(b"Z\r")
    assert ctrl.south_centre
    s.feed(b"M000\r")                             # south-centred scale: 0 = needle start
    clock.advance(200)
    assert ctrl.antenna()[0] == 180.0 and s.feed(b"C\r") == b"AZ=000\r\n"
    _ctrl2, s2, clock2 = make(readback_360=True)
    s2.feed(b"M400\r")
    clock2.advance(200)
    assert s2.feed(b"C\r") == b"AZ=040\r\n"


def test_manual_strict_and_one_space_options():
    _, s, _ = make(strict_acks=True, one_space=True)
    assert s.feed(b"W010 010\r") == b"\r"
    assert s.feed(b"C2\r") == b"AZ=000 EL=000\r\n"


def test_full_scale_dialogue_streams_until_enter():
    _ctrl, s, clock = make()
    assert s.feed(b"F2\r") == b""
    assert s.poll() == b"AZ=000EL=000\r\n"
    assert s.poll() == b""                        # next reading after 0.5 s
    clock.advance(0.5)
    assert s.poll() == b"AZ=000EL=000\r\n"
    s.feed(b"\r")
    clock.advance(1)
    assert s.poll() == b""
    assert s.feed(b"O\r") == b"are you sure?\r\n" and s.feed(b"y\r") == b"Completed.\r\n"


def test_help_screens_as_in_the_manuals():
    _, s, _ = make("gs232a")
    h = s.feed(b"H\r")
    assert h.startswith(b"-----COMMAND LIST 1-----\r\n")
    assert h.endswith(b"(V1.2) Copyright 1988.6 by KENPRO\r\n")
    _, b, _ = make()
    assert b.feed(b"h2\r").startswith(b"---------- HELP COMMAND 2 ----------\r\n")
    assert b"mode 450 Degree\r\nN Center" in b.feed(b"H3\r")


def test_autobaud_power_cycle_and_faults():
    ctrl, s, _clock = make(autobaud=True)
    assert s.feed(b"C2\r") == b""                 # not connected yet: no reply
    assert s.feed(b"\r") == b""                   # autobaud needs a few CRs
    assert s.feed(b"\r") == b"Connect OK\r\n"
    assert s.feed(b"C2\r") == b"AZ=000  EL=000\r\n"
    s.feed(b"M005 010 020\r")
    ctrl.power_cycle()
    assert s.feed(b"T\r") == b"?>\r\n"            # memory lost
    ctrl.faults.silent = True
    assert s.feed(b"C2\r") == b""
    ctrl.faults.silent = False
    ctrl.faults.reply_filter = lambda r: r[:3]    # drop bytes
    assert s.feed(b"C2\r") == b"AZ="


def test_lf_as_a_command_variant():
    ctrl = Gs232Controller(
        "gs232b", clock=ManualClock(datetime.fromisoformat(T0)))
    ctrl.profile = ctrl.profile.with_(lf_is_command=True)
    s = ctrl.open_session()
    assert s.feed(b"C2\r\n") == b"AZ=000  EL=000\r\n?>\r\n"   # LVB Tracker behaviour


def test_tcp_server_many_clients_drop_and_clean_close():
    ctrl, _, _ = make()
    server = serve_tcp(ctrl)
    host, port = server.url.removeprefix("socket://").split(":")
    socks = [socket.create_connection((host, int(port)), timeout=2) for _ in range(3)]
    for sk in socks:
        sk.sendall(b"C2\r")
        assert sk.recv(64) == b"AZ=000  EL=000\r\n"
    assert wait_until(lambda: server.connections == 3)
    server.drop_connections()
    assert wait_until(lambda: server.connections == 0)
    assert all(sk.recv(64) == b"" for sk in socks)
    again = socket.create_connection((host, int(port)), timeout=2)   # reconnect works
    again.sendall(b"C\r")
    assert again.recv(64) == b"AZ=000\r\n"
    server.close()
    assert server.closed and not server.thread.is_alive() and server.connections == 0
    assert again.recv(64) == b""
    for sk in [*socks, again]:
        sk.close()
    with pytest.raises(OSError):
        socket.create_connection((host, int(port)), timeout=1)
