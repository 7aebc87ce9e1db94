"""Hamlib's rotctl as the independent peer for the Rotor-EZ (model 401) and DCU-1 (403)
emulators over a real pty: it sets, reads back (401 only: the DCU-1 has no query) and stops,
and the emulated antenna really moves."""

from __future__ import annotations

import pytest
from _gs232_helpers import advance_until, wait_until
from _rigs import EmulatedRig, require_rotctl, rotctl

pytestmark = pytest.mark.hamlib

require_rotctl()


@pytest.fixture
def emulator(request):
    rig = EmulatedRig(request.param, "pty", 20.0)
    yield rig.ctrl, rig.server
    rig.close()
    rig.assert_released()


@pytest.mark.parametrize("emulator", ["rotorez"], indirect=True)
def test_rotctl_401_sets_reads_back_and_stops(emulator):
    ctrl, server = emulator
    rotctl("401", server.url, "P", "80", "0")
    assert wait_until(lambda: b"AM1;" in [c for _t, c, _r in ctrl.log])   # it is moving
    assert advance_until(ctrl.clock, lambda: ctrl.antenna() == 80.0), ctrl.antenna()
    # read back, then a long move (250 deg the long way round: south stop) in one session
    out = rotctl("401", server.url, "p", "P", "190", "0").stdout.split()
    assert float(out[0]) == 80.0
    assert wait_until(lambda: ctrl.moving(), 5)
    out = rotctl("401", server.url, "S", "p", "C", "jam", "0", "C", "endpt", "0").stdout.split()
    assert wait_until(lambda: not ctrl.moving(), 5)
    held = ctrl.antenna()
    assert held not in (80.0, 190.0)
    assert float(out[0]) == round(held) % 360
    cmds = [c for _t, c, _r in ctrl.log]
    assert cmds[:3] == [b"AP1080;", b"AM1;", b"AI1;"] and b";" in cmds
    # option bytes (Hamlib set_conf): jam protection and endpoint off, one byte each
    assert cmds[-2:] == [b"j", b"e"]
    assert not ctrl.settings["jam"] and not ctrl.settings["endpoint"]


@pytest.mark.parametrize("emulator", ["dcu1"], indirect=True)
def test_rotctl_403_sets_and_stops(emulator):
    ctrl, server = emulator
    rotctl("403", server.url, "P", "170", "0")     # 350 deg the long way round (south stop)
    assert wait_until(lambda: ctrl.moving(), 5)
    rotctl("403", server.url, "S")
    assert wait_until(lambda: not ctrl.moving(), 5)
    assert ctrl.antenna() != 170.0
    rotctl("403", server.url, "P", "200", "0")
    assert wait_until(lambda: ctrl.log[-1][1] == b"AM1;")
    assert advance_until(ctrl.clock, lambda: ctrl.antenna() == 200.0), ctrl.antenna()
    r = rotctl("403", server.url, "p", ok=False)      # no query on a DCU-1
    assert "Feature not available" in r.stdout + r.stderr
    cmds = [c for _t, c, _r in ctrl.log]
    assert cmds == [b"AP1170;", b"AM1;", b"AS1;", b"AP1200;", b"AM1;"]
