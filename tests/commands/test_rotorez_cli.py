"""``tracker rotator --protocol X`` for the other controllers against their emulators over a
real TCP socket (and ``tracker emulate --protocol X`` as a real subprocess), rotctld
against a real ``rotctld -m 1``."""

from __future__ import annotations

import shutil
import time

import pytest
from _gs232_helpers import WAIT_S, wait_until
from _rigs import EmulatedRig

from tracker.cli import main


@pytest.fixture
def emulator():
    """``emulator(protocol)`` -> (controller, server) on a real TCP socket, leak-checked."""
    rigs = []

    def make(protocol):
        rigs.append(EmulatedRig(protocol, "tcp", 200.0))
        return rigs[-1].ctrl, rigs[-1].server
    yield make
    for rig in rigs:
        rig.close()
    for rig in rigs:
        rig.assert_released()


def _rot(capsys, url, protocol, *action):
    rc = main(["rotator", "--port", url, "--protocol", protocol, *action])
    out, err = capsys.readouterr()
    return rc, out.strip(), err.strip()


def test_rotorez_goto_position_stop(emulator, capsys):
    ctrl, server = emulator("rotorez")
    assert _rot(capsys, server.url, "rotorez", "goto", "90")[0] == 0
    assert wait_until(lambda: ctrl.antenna() == 90.0, 10)
    assert _rot(capsys, server.url, "rotorez", "position") == (0, "90", "")
    assert _rot(capsys, server.url, "rotorez", "stop")[0] == 0
    rc, out, _err = _rot(capsys, server.url, "rotorez", "--ignore-limits", "raw", "V")
    assert rc == 0 and "IDIOM" in out


@pytest.mark.parametrize("protocol", ["dcu1", "sak232"])
def test_open_loop_goto_stop_and_no_position(emulator, capsys, protocol):
    ctrl, server = emulator(protocol)
    assert _rot(capsys, server.url, protocol, "goto", "45")[0] == 0
    assert wait_until(lambda: abs(ctrl.antenna() - 45.0) < 1, 10), ctrl.antenna()
    rc, _out, err = _rot(capsys, server.url, protocol, "position")
    assert rc == 2 and err.startswith("tracker: error:") and "no position query" in err
    assert "Traceback" not in err
    assert _rot(capsys, server.url, protocol, "stop")[0] == 0


def test_azaz_both_antennas(emulator, capsys):
    ctrl, server = emulator("gs232b-azaz")
    assert _rot(capsys, server.url, "gs232b-azaz", "goto", "100")[0] == 0
    assert _rot(capsys, server.url, "gs232b-azaz2", "goto", "300")[0] == 0
    assert wait_until(lambda: ctrl.antenna() == (100.0, 300.0), 10), ctrl.antenna()
    assert _rot(capsys, server.url, "gs232b-azaz", "position") == (0, "100", "")
    assert _rot(capsys, server.url, "gs232b-azaz2", "position") == (0, "300", "")


def test_bad_input_is_one_line_exit_2(emulator, capsys):
    _ctrl, server = emulator("rotorez")
    rc, _out, err = _rot(capsys, server.url, "rotorez", "goto", "400")
    assert rc == 2 and "outside" in err and len(err.splitlines()) == 1
    rc, _out, err = _rot(capsys, "nohost:notaport", "rotctld", "position")
    assert rc == 2 and "host:port" in err


def test_emulate_subprocess_serves_each_protocol(emulate, capsys):
    protocols = ("rotorez", "dcu1", "sak232", "gs232b-azaz")
    # all started before the first is read: four interpreters start together
    procs = [emulate("--protocol", p, "--tcp", "0", "--speed", "50", url_now=False)
             for p in protocols]
    for protocol, proc in zip(protocols, procs, strict=True):
        url = proc.read_url()
        assert url.startswith("socket://127.0.0.1:"), url
        assert _rot(capsys, url, protocol, "goto", "10")[0] == 0
    for protocol, proc in zip(protocols, procs, strict=True):
        deadline = time.monotonic() + WAIT_S
        seen = ""
        while time.monotonic() < deadline and " 10.0" not in seen:
            seen = proc.readline()
        assert " 10.0" in seen, (protocol, seen)   # the status line: antenna at 10
        assert proc.stop()[0] == 0


@pytest.mark.hamlib
@pytest.mark.skipif(shutil.which("rotctld") is None, reason="Hamlib rotctld not installed")
def test_rotctld_via_cli(capsys):
    from _rigs import start_rotctld

    proc, port = start_rotctld("-m", "1")
    try:
        assert _rot(capsys, f"127.0.0.1:{port}", "rotctld", "position") == (0, "0 0", "")
        assert _rot(capsys, f"rotctld://127.0.0.1:{port}", "rotctld", "goto", "5", "5")[0] == 0
        assert _rot(capsys, f"127.0.0.1:{port}", "rotctld", "stop")[0] == 0
        rc, _out, err = _rot(capsys, f"127.0.0.1:{port}", "rotctld", "goto", "10", "95")
        assert rc == 2 and "elevation" in err
    finally:
        proc.terminate()
        proc.wait(5)
