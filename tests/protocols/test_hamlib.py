"""Hamlib's rotctl as the independent peer: it sets a position, reads it back and stops
against the emulator on a real pty, and the emulated antenna really moves there."""

from __future__ import annotations

import pytest
from _gs232_helpers import wait_until
from _rigs import EmulatedRig, require_rotctl
from _rigs import rotctl as run_rotctl

pytestmark = pytest.mark.hamlib

require_rotctl()

# (Hamlib model, emulator profile, transport). Hamlib 4.5.4's models: 603 GS-232B, 601
# GS-232A, 605 GS-23 and 606 GS-232 (both parse C2 as +0aaa+0eee, like 601). Hamlib opens
# "host:port" as a network port, so the same serial backends also run over TCP.
MODELS = [("603", "gs232b", "pty"), ("601", "gs232a", "pty"), ("605", "gs23", "pty"),
          ("606", "gs232a", "pty"), ("606", "gs23", "pty"), ("603", "gs232b-manual", "pty"),
          ("603", "k3ng", "pty"), ("603", "gs232b", "tcp"), ("601", "gs232a", "tcp")]


def rotctl(model: str, url: str, *cmds: str) -> str:
    return run_rotctl(model, url, *cmds).stdout


@pytest.fixture
def emulator(request):
    profile, kind = request.param if isinstance(request.param, tuple) else (request.param,
                                                                            "pty")
    rig = EmulatedRig(profile, kind, 100.0)
    server = rig.server
    server.rotctl_path = server.url.removeprefix("socket://")   # rotctl -r host:port
    yield rig.ctrl, server
    rig.close()
    rig.assert_released()


def _wire_log(ctrl) -> list[tuple[bytes, bytes]]:
    """What the emulator received and answered: the evidence when a check fails."""
    return [(line, reply) for _t, line, reply in ctrl.log]


@pytest.mark.parametrize(("model", "emulator"), [(m, (p, k)) for m, p, k in MODELS],
                         indirect=["emulator"], ids=[f"{m}-{p}-{k}" for m, p, k in MODELS])
def test_rotctl_set_read_back_stop(model, emulator):
    ctrl, server = emulator
    rotctl(model, server.rotctl_path, "P", "180", "45")
    assert wait_until(lambda: ctrl.antenna() == (180.0, 45.0), 10), \
        (ctrl.antenna(), _wire_log(ctrl))
    out = rotctl(model, server.rotctl_path, "p", "S").split()
    assert [float(v) for v in out[:2]] == [180.0, 45.0], (out, _wire_log(ctrl))
    lines = [line for line, _reply in _wire_log(ctrl)]
    assert b"W180 045" in lines and lines[-1] in (b"S", b""), _wire_log(ctrl)
    assert b"S" in lines


STOP_MODELS = [("603", "gs232b"), ("601", "gs232a"), ("605", "gs23"), ("606", "gs23")]


@pytest.mark.parametrize(("model", "emulator"), STOP_MODELS, indirect=["emulator"],
                         ids=[f"{m}-{p}" for m, p in STOP_MODELS])
def test_rotctl_stop_halts_a_running_move(model, emulator):
    ctrl, server = emulator
    rotctl(model, server.url, "P", "450", "180")
    assert wait_until(lambda: ctrl.antenna()[0] > 10, 10), _wire_log(ctrl)
    rotctl(model, server.url, "S")
    # a GS-232B does not answer S: rotctl may return before the emulator has read it
    assert wait_until(lambda: not ctrl.moving(), 5), _wire_log(ctrl)
    stopped = ctrl.antenna()
    assert stopped[0] < 450 and stopped[1] < 180
    az, el = (float(v) for v in rotctl(model, server.url, "p").split()[:2])
    assert (az, el) == (round(stopped[0]), round(stopped[1]))


@pytest.mark.parametrize("emulator", ["gs232b"], indirect=True)
def test_rotctl_reads_controller_off(emulator):
    ctrl, server = emulator
    ctrl.set_rotator_power(False)
    out = rotctl("603", server.url, "p").split()
    assert [float(v) for v in out[:2]] == [-1.0, -2.0]
