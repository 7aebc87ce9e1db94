"""The rotctld-compatible control port over real 127.0.0.1 sockets: Hamlib's own ``rotctl -m
2`` (netrotctl) and a raw client, in front of in-process emulators (``emu://`` benches on a
fast SimClock). Every refusal is checked on what the controller received."""

from __future__ import annotations

import socket
from datetime import datetime

import pytest
from _gs232_helpers import T0, WAIT_S, wait_until
from _rigs import require_rotctl, rotctl

from tracker.clock import SimClock
from tracker.emulator.factory import make_emulator
from tracker.emulator.virtual import Bench
from tracker.mount import preset
from tracker.protocols import open_driver
from tracker.service.board import StatusBoard
from tracker.service.rotctld_server import (
    RotctldServer,
    is_loopback,
    listen_address,
    parse_line,
)
from tracker.session import driver_limits
from tracker.station import HorizonMask, Station

require_rotctl()

SPEED = 20.0   # fast enough for the motors, slow enough that the stall watch sees each step


class Served:
    """An emulator behind an ``emu://`` bench, and a control port in front of it."""

    def __init__(self, protocol: str, rotator: str, *, station=None, board=None,
                 hand_over: bool = True):
        self.clock = SimClock(datetime.fromisoformat(T0), speed=SPEED)
        self.spec = preset(rotator)
        self.box = make_emulator(protocol, self.clock, self.spec)
        self.bench = Bench(self.box)
        kw = {**driver_limits(self.spec), "clock": self.clock}
        if protocol == "sak232":
            kw["spec"] = self.spec
        self.events: list[tuple[str, str]] = []
        self.board = board
        self.server = RotctldServer(
            lambda: open_driver(self.bench.url, protocol, **kw), self.spec, station=station,
            clock=self.clock, port=0, board=board,
            events=lambda kind, **d: self.events.append((kind, str(d.get("text")))))
        self.server.start()
        if hand_over:
            self.server.hand_over()
        self.url = self.server.listen

    def written(self) -> bytes:
        return self.bench.bytes_written()

    def rotctl(self, *cmds: str, ok: bool = True):
        return rotctl("2", self.url, *cmds, ok=ok)

    def close(self) -> None:
        self.server.close()
        self.bench.close()


@pytest.fixture
def served():
    made: list[Served] = []

    def make(*args, **kw) -> Served:
        s = Served(*args, **kw)
        made.append(s)
        return s
    yield make
    for s in made:
        s.close()


class Client:
    """A raw rotctld client: one line in, the reply bytes out."""

    def __init__(self, url: str):
        host, port = url.split(":")
        self.sock = socket.create_connection((host, int(port)), timeout=WAIT_S)
        self.buf = b""

    def ask(self, line: str, lines: int = 1) -> list[str]:
        self.sock.sendall(line.encode() + b"\n")
        while self.buf.count(b"\n") < lines:
            chunk = self.sock.recv(65536)
            if not chunk:
                break
            self.buf += chunk
        *out, self.buf = self.buf.split(b"\n", lines)
        return [x.decode() for x in out]

    def close(self) -> None:
        self.sock.close()


def test_rotctl_drives_a_gs232b_through_the_port(served):
    s = served("gs232b", "G-5500")
    assert s.rotctl("p").stdout.split() == ["0.00", "0.00"]
    s.rotctl("P", "100", "30")
    assert wait_until(lambda: b"W100 030\r" in s.written())
    assert wait_until(lambda: float(s.rotctl("p").stdout.split()[0]) > 1.0)
    s.rotctl("S")
    assert _last_command(s.written()) == b"S"
    s.rotctl("K")                       # the G-5500's park: az 0, el 0
    assert _last_command(s.written()) == b"W000 000"
    assert s.rotctl("_").stdout.strip() == "tracker control port: G-5500"


def test_rotctl_drives_a_sak232_which_hamlib_has_no_backend_for(served):
    s = served("sak232", "Zelpro-RAU")
    s.rotctl("P", "100", "0")
    assert s.written().endswith(b"A 100\r")
    # no position query: p is the driver's motor-model estimate, turning toward 100
    assert wait_until(lambda: float(s.rotctl("p").stdout.split()[0]) > 1.0)
    s.rotctl("S")
    assert s.written().endswith(b"S\r")
    s.rotctl("K")
    assert s.written().endswith(b"A %d\r" % round(s.spec.park_az_deg))


def test_long_forms_dump_state_and_extended_replies(served):
    s = served("gs232b", "G-5500")
    c = Client(s.url)
    try:
        assert c.ask("\\dump_state", 9) == [
            "1", "2", "min_az=0.000000", "max_az=450.000000", "min_el=0.000000",
            "max_el=180.000000", "south_zero=0", "rot_type=AzEl", "done"]
        assert c.ask("\\get_pos", 2) == ["0.00", "0.00"]
        assert c.ask("\\set_pos 10 20") == ["RPRT 0"]
        assert b"W010 020\r" in s.written()
        assert c.ask("+\\get_pos", 4)[0::3] == ["get_pos:", "RPRT 0"]
        assert c.ask(";\\stop") == ["stop:;RPRT 0"]
        assert c.ask("\\park") == ["RPRT 0"]
        assert c.ask("\\get_info") == ["tracker control port: G-5500"]
        assert c.ask("+_", 3) == ["get_info:", "Info: tracker control port: G-5500",
                                  "RPRT 0"]
        assert c.ask("\\bogus") == ["RPRT -4"]
        assert c.ask("M 8 50") == ["RPRT -11"]      # a continuous move cannot be guarded
        caps = c.ask("\\dump_caps", 14)
        assert "Max Azimuth:\t\t450.00" in caps and caps[-1] == "RPRT 0"
        c.sock.sendall(b"q\n")
        assert c.sock.recv(100) == b""                # q closes the connection
    finally:
        c.close()


def test_the_tools_own_rotctld_driver_reads_the_ports_limits(served):
    s = served("gs232b", "G-5500")
    drv = open_driver(s.url, "rotctld", timeout_s=WAIT_S)
    try:
        assert drv.az_limits == (0.0, 450.0) and drv.el_limits == (0.0, 180.0)
        drv.goto(200, 10)
        assert b"W200 010\r" in s.written()
    finally:
        drv.close()


MASKED = Station("Delft", 52.0, 4.37, 0.0, min_el_deg=5.0,
                 mask=HorizonMask((0.0, 90.0, 180.0, 270.0), (0.0, 25.0, 0.0, 0.0)))


def _moves(written: bytes) -> list[bytes]:
    return [x for x in written.split(b"\r") if x.startswith(b"W")]


def _last_command(written: bytes) -> bytes:
    """The last command that was not a position query (the stall watch keeps reading)."""
    return [x for x in written.split(b"\r") if x and x != b"C2"][-1]


def test_moves_outside_the_limits_or_below_the_mask_are_refused_and_nothing_is_sent(served):
    s = served("gs232b", "G-5500", station=MASKED)
    c = Client(s.url)
    try:
        assert c.ask("P 460 30") == ["RPRT -1"]          # beyond the 450 deg span
        assert c.ask("P 100 -3") == ["RPRT -1"]          # below the elevation range
        assert c.ask("P abc 30") == ["RPRT -1"]
        assert c.ask("P 1_0 30") == ["RPRT -1"]         # float() would read this as 10
        assert c.ask("P nan 30") == ["RPRT -1"]
        assert c.ask("P 100 inf") == ["RPRT -1"]
        assert c.ask("P 1e999 30") == ["RPRT -1"]
        assert c.ask("P 100") == ["RPRT -1"]
    finally:
        c.close()
    r = s.rotctl("P", "90", "10", ok=False)             # the mask is 25 deg at bearing 90
    assert r.returncode != 0 and "Invalid parameter" in r.stdout + r.stderr
    assert _moves(s.written()) == []
    refusals = [t for k, t in s.events if k == "refused"]
    assert len(refusals) == 9 and "horizon mask" in refusals[-1]
    s.rotctl("P", "90", "30")                           # above it: goes
    assert _moves(s.written()) == [b"W090 030"]


def test_a_move_whose_way_dips_below_the_mask_is_refused(served):
    s = served("gs232b", "G-5500", station=MASKED)
    s.rotctl("P", "0", "10")                            # from a low park: the end counts
    assert wait_until(lambda: s.rotctl("p").stdout.split() == ["0.00", "10.00"])
    r = s.rotctl("P", "180", "10", ok=False)            # passes bearing 90 (mask 25) at 10
    assert r.returncode != 0
    assert _moves(s.written()) == [b"W000 010"]
    assert "on its way" in s.events[-1][1]


def test_take_back_stops_the_outside_move_and_answers_busy_then_hand_over(served):
    board = StatusBoard(SimClock(datetime.fromisoformat(T0)))
    s = served("gs232b", "G-5500", board=board)
    s.rotctl("P", "200", "40")
    assert board.status()["control_port"]["owner"] == "outside"
    s.server.take_back("pass of ISS at 12:05")
    assert _last_command(s.written()) == b"S"           # the outside move was stopped
    assert s.bench.connections == 0                      # the port is free for the station
    assert s.server.owner == "station"
    assert board.status()["control_port"]["owner"] == "station"
    before = s.written()
    r = s.rotctl("P", "100", "30", ok=False)
    assert r.returncode != 0 and "Command rejected" in r.stdout + r.stderr
    board.set_antenna(123.0, 45.0)                      # the station's own read-back
    assert s.rotctl("p").stdout.split() == ["123.00", "45.00"]
    assert s.written() == before                         # nothing reached the controller
    s.server.hand_over()
    s.rotctl("P", "100", "30")
    assert _last_command(s.written()) == b"W100 030"
    assert board.status()["antenna"] is not None


def test_position_while_the_station_holds_it_without_a_board_is_refused(served):
    s = served("gs232b", "G-5500", hand_over=False)
    c = Client(s.url)
    try:
        assert c.ask("p") == ["RPRT -9"]
        assert c.ask("S") == ["RPRT -9"]
    finally:
        c.close()
    assert s.written() == b""


def test_a_jammed_motor_is_caught_re_sent_stopped_and_reported(served):
    board = StatusBoard(SimClock(datetime.fromisoformat(T0)))
    s = served("gs232b", "G-5500", board=board)
    s.box.jam("az")
    s.rotctl("P", "100", "0")
    assert wait_until(lambda: any(k == "stall" for k, _t in s.events), WAIT_S * 3)
    text = next(t for k, t in s.events if k == "stall")
    assert "azimuth did not move" in text and "the rotator was stopped" in text
    assert _last_command(s.written()) == b"S"
    # a lost command is not a stall: the move was re-sent before it was judged
    assert _moves(s.written()).count(b"W100 000") >= 2
    assert any("did not move" in f["text"] for f in board.status()["faults"])


def test_a_client_leaving_mid_move_does_not_stop_but_close_does(served):
    s = served("gs232b", "G-5500")
    c = Client(s.url)
    assert c.ask("P 300 60") == ["RPRT 0"]
    c.close()
    other = Client(s.url)                 # a second client still works meanwhile
    try:
        assert len(other.ask("p", 2)) == 2
    finally:
        other.close()
    assert b"S" not in s.written().split(b"\r")
    s.server.close()
    assert _last_command(s.written()) == b"S"


def test_a_command_cut_short_by_a_disconnect_is_not_run(served):
    s = served("gs232b", "G-5500")
    with socket.create_connection(s.url.split(":"), timeout=WAIT_S) as cut:
        cut.sendall(b"P 100 3")                # "P 100 35" cut short
    c = Client(s.url)
    try:
        assert c.ask("\\") == ["RPRT -4"]     # a bare backslash: unknown, the client stays
        assert len(c.ask("p", 2)) == 2
    finally:
        c.close()
    assert _moves(s.written()) == []


def test_a_line_without_end_is_refused_and_does_not_hold_up_the_others(served):
    s = served("gs232b", "G-5500")
    with socket.create_connection(s.url.split(":"), timeout=WAIT_S) as hog:
        hog.sendall(b"P " + b"9" * 100_000)
        assert hog.recv(100) == b"RPRT -1\n"
        assert hog.recv(100) == b""              # and closed
        other = Client(s.url)
        try:
            assert other.ask("P 10 10") == ["RPRT 0"]
        finally:
            other.close()
    assert _moves(s.written()) == [b"W010 010"]
    assert any("longer than 1024 bytes" in t for k, t in s.events if k == "refused")


def test_several_clients_at_once_and_the_board_counts_them(served):
    board = StatusBoard(SimClock(datetime.fromisoformat(T0)))
    s = served("gs232b", "G-5500", board=board)
    a, b = Client(s.url), Client(s.url)
    try:
        assert wait_until(lambda: board.status()["control_port"]["clients"] == 2)
        for _ in range(5):
            assert len(a.ask("p", 2)) == 2 and b.ask("P 10 10") == ["RPRT 0"]
        assert board.status()["control_port"]["listen"] == s.url
    finally:
        a.close()
        b.close()
    assert wait_until(lambda: board.status()["control_port"]["clients"] == 0)


def test_parse_line_and_addresses():
    assert parse_line("+\\set_pos 1 2\n") == ("\n", "P", ["1", "2"])
    assert parse_line(";p") == (";", "p", [])
    assert parse_line("P 10 20") == (None, "P", ["10", "20"])
    assert listen_address("0.0.0.0:4600") == ("0.0.0.0", 4600)
    assert listen_address("localhost") == ("localhost", 4533)
    assert is_loopback("127.0.0.1") and is_loopback("::1") and not is_loopback("0.0.0.0")
