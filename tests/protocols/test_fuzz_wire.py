"""Fuzz over the real wire: garbage into every emulator over a pty and TCP (it must keep
serving and answer afterwards), and garbage replies from a raw peer into the drivers (typed
errors within the timeout, never a hang)."""

from __future__ import annotations

import random
import socket
import time
from datetime import datetime

import pytest
from _fuzz_targets import TOKENS, mutate
from _gs232_helpers import T0, RawPeer, wait_until

from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_pty, serve_tcp
from tracker.emulator.factory import make_emulator
from tracker.errors import LimitError, PortLostError, ProtocolError, RotatorTimeout
from tracker.protocols import open_driver

ALIVE = {"gs232b": (b"C2\r", b"AZ="), "k3ng": (b"C2\r", b"AZ="), "gs232a": (b"C2\r", b"+0"),
         "rotorez": (b"AI1;", b";"), "gs232b-azaz": (b"C2\r", b"AZ=")}


def _garbage(rng: random.Random) -> list[bytes]:
    chunks = [bytes(rng.randrange(256) for _ in range(rng.randint(1, 300))) for _ in range(20)]
    chunks += [b"".join(rng.choice(TOKENS) for _ in range(40)) for _ in range(20)]
    chunks += [mutate(rng, b"W180 045\rM005 010 020 030\rT\rC2\r", TOKENS) for _ in range(20)]
    chunks.append(b"W" * 70000)          # longer than any line buffer, no terminator
    chunks.append(b"\x00\xff" * 5000)
    rng.shuffle(chunks)
    return chunks


class _Client:
    """A raw byte client on the server's URL (socket or the pty slave)."""

    def __init__(self, url: str):
        import serial

        self.port = serial.serial_for_url(url, timeout=0.05, write_timeout=2)

    def send(self, data: bytes) -> None:
        self.port.write(data)

    def ask(self, data: bytes, marker: bytes, timeout_s: float = 2.0) -> bytes:
        self.port.reset_input_buffer()
        self.port.write(data)
        got = bytearray()
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and marker not in got:
            got += self.port.read(256)
        return bytes(got)

    def close(self) -> None:
        self.port.close()


@pytest.mark.parametrize("kind", ["tcp", "pty"])
@pytest.mark.parametrize("protocol", list(ALIVE))
def test_emulator_survives_garbage_over_the_wire(kind, protocol):
    clock = SimClock(datetime.fromisoformat(T0), speed=20.0)
    if protocol in ("rotorez", "gs232b-azaz"):
        ctrl = make_emulator(protocol, clock)
    else:
        ctrl = Gs232Controller(protocol, clock=clock)
    server = serve_tcp(ctrl) if kind == "tcp" else serve_pty(ctrl)
    client = _Client(server.url)
    try:
        for chunk in _garbage(random.Random(hash(protocol) & 0xffff)):
            client.send(chunk)
        time.sleep(0.2)
        query, marker = ALIVE[protocol]
        client.send(b";\r\r\r")
        time.sleep(0.1)
        reply = client.ask(query, marker)
        assert marker in reply, reply[-200:]
        assert server.thread.is_alive() and server.errors == []
    finally:
        client.close()
        server.close()
    assert server.closed and not server.thread.is_alive()


def test_emulator_keeps_serving_other_clients_after_a_flood():
    ctrl = Gs232Controller("gs232b")
    server = serve_tcp(ctrl)
    host, port = server.url.removeprefix("socket://").split(":")
    try:
        flood = socket.create_connection((host, int(port)), timeout=2)
        flood.sendall(b"\xff" * 200000)
        other = socket.create_connection((host, int(port)), timeout=2)
        other.sendall(b"C2\r")
        assert other.recv(64) == b"AZ=000  EL=000\r\n"
        assert wait_until(lambda: server.thread.is_alive() and server.errors == [], 1)
        flood.close()
        other.close()
    finally:
        server.close()


# Garbage replies into the drivers ---------------------------------------------------------

REPLY_SEEDS = [b"AZ=123  EL=045\r\n", b"+0123+0045\r\n", b"AI1;123;", b";123", b"123\n45\n",
               b"RPRT -8\n", b"?>\r\n", b"AZ=123EL=045\r\n"]
DRIVERS = {"gs232b": {"retries": 0}, "k3ng": {"retries": 0}, "rotorez": {"retries": 0},
           "rotctld": {"read_caps": False}, "gs232b-azaz": {"retries": 0}}
TIMEOUT_S = 0.1
N_REPLIES = 12


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["tcp", "pty"])
@pytest.mark.parametrize("protocol", list(DRIVERS))
def test_driver_turns_garbage_replies_into_typed_errors(kind, protocol):
    if kind == "pty" and protocol == "rotctld":
        pytest.skip("rotctld is a TCP protocol")
    rng = random.Random(5)
    current = [b""]
    peer = RawPeer(kind, lambda req: current[0])
    outcomes: dict[str, int] = {}
    try:
        d = open_driver(peer.url, protocol, timeout_s=TIMEOUT_S, **DRIVERS[protocol])
        d.stop_on_exit = False
        for _ in range(N_REPLIES):
            r = rng.random()
            if r < 0.6:
                current[0] = mutate(rng, rng.choice(REPLY_SEEDS), TOKENS, max_ops=3)
            elif r < 0.8:
                current[0] = bytes(rng.randrange(256) for _ in range(rng.randint(0, 40)))
            else:
                current[0] = b"".join(rng.choice(TOKENS) for _ in range(10))
            t0 = time.monotonic()
            try:
                d.position()
                key = "reading"
            except (RotatorTimeout, ProtocolError, PortLostError, LimitError) as e:
                key = type(e).__name__
            assert time.monotonic() - t0 < 3 * TIMEOUT_S + 1.0
            outcomes[key] = outcomes.get(key, 0) + 1
        d.close()
    finally:
        peer.close()
    assert sum(outcomes.values()) == N_REPLIES
    assert set(outcomes) - {"reading"}, outcomes     # garbage was noticed at least once


@pytest.mark.parametrize("caps", [b"Min Azimuth:\t\t1.2.3\n", b"Max Elevation:\t.\n",
                                  b"Max Azimuth: -\n", b"Min Elevation: 1e999\n",
                                  b"Max Azimuth:\t\t450.00 junk\n"])
def test_rotctld_garbled_dump_caps_is_ignored_not_a_crash(caps):
    """Found by fuzzing: ``\\dump_caps`` limits matched ``-?[\\d.]+`` and went to float(), so
    a garbled line such as ``1.2.3`` raised ValueError out of open_driver. Now a line that
    is not exactly a number is ignored and the configured limits stay in force."""
    peer = RawPeer("tcp", lambda req: caps + b"RPRT 0\n")
    try:
        d = open_driver(peer.url, "rotctld", timeout_s=0.5)
        d.stop_on_exit = False
        assert d.az_limits == (-180.0, 450.0) and d.el_limits == (0.0, 180.0)
        d.close()
    finally:
        peer.close()


def test_rotctld_real_dump_caps_format_still_read():
    """The format Hamlib 4 really prints (tabs, two decimals) still narrows the limits."""
    caps = (b"Min Azimuth:\t\t-180.00\nMax Azimuth:\t\t450.00\nMin Elevation:\t\t0.00\n"
            b"Max Elevation:\t\t90.00\nRPRT 0\n")
    peer = RawPeer("tcp", lambda req: caps)
    try:
        d = open_driver(peer.url, "rotctld", timeout_s=0.5)
        d.stop_on_exit = False
        assert d.el_limits == (0.0, 90.0)
        d.close()
    finally:
        peer.close()
