"""The rotctld client against a real Hamlib ``rotctld -m 1`` (dummy) on a free 127.0.0.1
port, and the three-party chain tracker → ``rotctld -m 603 -r /dev/pts/N`` → the project's
GS-232B emulator (the emulated antenna really moves)."""

from __future__ import annotations

import os
import time
from datetime import datetime

import pytest
from _gs232_helpers import T0, RawPeer, advance_until, wait_until
from _rigs import ROTCTLD, start_rotctld

from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_pty
from tracker.errors import ConfigError, LimitError, ProtocolError, RotatorTimeout
from tracker.mount import preset
from tracker.protocols import open_driver
from tracker.protocols.rotctld import rotctld_url, rprt_error  # registers "rotctld"


def test_url_forms_and_rprt_mapping():
    assert rotctld_url("rotctld://127.0.0.1:4533") == "socket://127.0.0.1:4533"
    assert rotctld_url("127.0.0.1:5000") == "socket://127.0.0.1:5000"
    assert rotctld_url("localhost") == "socket://localhost:4533"
    for bad in ("127.0.0.1:x", ":4533", "h:70000"):
        with pytest.raises(ConfigError):
            rotctld_url(bad)
    assert isinstance(rprt_error(-1, "P"), LimitError)
    assert isinstance(rprt_error(-5, "p"), RotatorTimeout)
    assert isinstance(rprt_error(-8, "p"), ProtocolError)
    assert isinstance(rprt_error(-11, "K"), ConfigError)
    assert "Feature not available" in str(rprt_error(-11, "K"))


def test_fake_daemon_errors_and_silence():
    """A raw TCP peer speaking rotctld's format: garbage, RPRT codes and silence."""
    replies = {b"\\dump_caps\n": b"Min Azimuth:\t\t0.00\nMax Azimuth:\t\t360.00\n"
                                 b"Min Elevation:\t\t0.00\nMax Elevation:\t\t90.00\nRPRT 0\n",
               b"p\n": b"12.5\nnot-a-number\n", b"S\n": b"RPRT -6\n", b"K\n": b"RPRT -11\n"}
    peer = RawPeer("tcp", lambda req: replies.get(req, b""))
    try:
        drv = open_driver(peer.url, "rotctld", timeout_s=0.3)
        assert drv.az_limits == (0.0, 360.0) and drv.el_limits == (0.0, 90.0)
        with pytest.raises(ProtocolError, match="two numbers"):
            drv.position()
        with pytest.raises(LimitError, match=r"0\.\.360"):
            drv.goto(400, 10)                       # narrower daemon limits win
        with pytest.raises(LimitError, match="elevation"):
            drv.goto(10, 95)
        with pytest.raises(ConfigError, match="Feature not available"):
            drv.park()
        from tracker.errors import RotatorIOError
        with pytest.raises(RotatorIOError, match="IO error"):
            drv.stop()
        with pytest.raises(RotatorTimeout, match=r"P 10\.00 10\.00"):
            drv.goto(10, 10)                         # the fake never answers P
        drv.close()
    finally:
        peer.close()
    assert b"P 400" not in peer.received and b"P 10.00 95" not in peer.received


# Real Hamlib --------------------------------------------------------------------------------

if ROTCTLD is None and os.environ.get("CI", "").lower() == "true":
    raise RuntimeError("rotctld not found but CI=true: install Debian's libhamlib-utils")
needs_hamlib = pytest.mark.skipif(ROTCTLD is None, reason="Hamlib rotctld not installed")




@pytest.fixture
def dummy():
    proc, port = start_rotctld("-m", "1")
    yield port
    proc.terminate()
    proc.wait(5)


@pytest.mark.hamlib
@needs_hamlib
def test_dummy_rotator_goto_read_stop_park_move(dummy):
    with open_driver(f"rotctld://127.0.0.1:{dummy}", "rotctld") as drv:
        assert drv.daemon_limits["Max Elevation"] == 90.0
        assert drv.info() == "Dummy rotator"
        assert drv.position() == (0.0, 0.0)
        drv.goto(20, 10)
        # the dummy turns slowly; it really moves toward the target
        assert wait_until(lambda: drv.position()[0] > 0.5, 5)
        drv.stop()
        az1, _ = drv.position()
        time.sleep(0.5)
        assert drv.position()[0] == pytest.approx(az1, abs=0.05)   # stopped
        drv.move("cw", 50)
        drv.stop()
        drv.park()
        with pytest.raises(LimitError, match="elevation"):
            drv.goto(10, 91)                        # rotctld's own limit (0..90) is narrower
    # without the client check, rotctld itself rejects the value: RPRT -1 -> LimitError
    with open_driver(f"127.0.0.1:{dummy}", "rotctld", check_limits=False) as drv:
        with pytest.raises(LimitError, match="RPRT -1"):
            drv.goto(500, 10)


@pytest.mark.hamlib
@needs_hamlib
def test_three_party_chain_to_the_gs232b_emulator():
    clock = SimClock(datetime.fromisoformat(T0), speed=20.0)
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock)
    server = serve_pty(ctrl)
    proc, port = start_rotctld("-m", "603", "-r", server.url)
    try:
        with open_driver(f"rotctld://127.0.0.1:{port}", "rotctld", timeout_s=5) as drv:
            drv.goto(180, 45)
            assert wait_until(lambda: any(c == b"W180 045" for _t, c, _r in ctrl.log))
            assert advance_until(clock, lambda: ctrl.antenna() == (180.0, 45.0)), \
                ctrl.antenna()
            assert drv.position() == (180.0, 45.0)
            drv.goto(20, 10)
            assert wait_until(ctrl.moving, 5)
            drv.stop()
            assert wait_until(lambda: not ctrl.moving(), 5)
            held = ctrl.antenna()
            assert held[0] > 20 and drv.position() == (round(held[0]), round(held[1]))
            with pytest.raises(ConfigError, match="not available"):
                drv.park()                    # the GS-232B backend has no park in 4.5.4
        lines = [line for _t, line, _r in ctrl.log]
        assert b"W180 045" in lines and b"C2" in lines and b"S" in lines
    finally:
        proc.terminate()
        proc.wait(5)
        server.close()
    assert server.closed


@pytest.mark.hamlib
@needs_hamlib
def test_daemon_gone_is_reported_not_hung():
    from tracker.errors import RotatorIOError

    proc, port = start_rotctld("-m", "1")
    try:
        drv = open_driver(f"127.0.0.1:{port}", "rotctld", timeout_s=0.5)
        assert drv.position() == (0.0, 0.0)
    finally:
        proc.terminate()
        proc.wait(5)
    t = time.monotonic()
    with pytest.raises(RotatorIOError):
        drv.position()
    assert time.monotonic() - t < 2.0
    drv.close()


@pytest.mark.hamlib
@pytest.mark.slow
@needs_hamlib
def test_tracker_track_through_rotctld_to_the_gs232b_emulator(tmp_path, capsys, monkeypatch):
    """``tracker track --protocol rotctld`` as a user runs it: a whole ISS pass through a
    real ``rotctld -m 603`` to the project's GS-232B emulator on a pty, all-stop at the end."""
    import json

    from tracker.cli import main

    # rotctld paces its GS-232B backend in real time (50 ms per write), and every reply comes
    # through two more processes: at 100x a loaded machine's delays were seconds of simulated
    # read-back lag, which the loop rightly judged inconsistent. At 25x they stay small.
    speed = 25.0
    clock = SimClock(datetime.fromisoformat("2026-08-23T02:06:05+00:00"), speed=speed)
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock)
    server = serve_pty(ctrl)
    proc, port = start_rotctld("-m", "603", "-r", server.url)
    cfg = tmp_path / "empty.toml"
    cfg.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(cfg))
    log = tmp_path / "track.jsonl"
    try:
        rc = main(["track", "ISS (ZARYA)", "--protocol", "rotctld", "--port",
                   f"127.0.0.1:{port}", "--at", "2026-08-23T02:06:05Z", "--speed", str(speed),
                   "--plain", "--stay", "--log", str(log)])
    finally:
        proc.terminate()
        proc.wait(5)
        server.close()
    assert rc == 0, capsys.readouterr()
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
    done = [r for r in recs if r["kind"] == "state" and r.get("state") == "pass_done"]
    assert len(gotos) >= 5 and len(done) == 1
    # the emulated antenna really went where the tracker sent it last (--stay), through
    # rotctld, and rotctld passed the final all-stop on
    az, el = ctrl.antenna()
    assert abs(az - gotos[-1]["az_m"]) <= 1.0 and abs(el - gotos[-1]["el"]) <= 1.0
    lines = [line for _t, line, _r in ctrl.log]
    assert b"S" in lines[-4:]
