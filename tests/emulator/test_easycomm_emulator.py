"""The Easycomm emulator over a real pty and a real TCP socket: the bytes Hamlib sends get
the answers Hamlib parses, and the antenna moves on the shared motor model."""

from __future__ import annotations

import pytest
from _gs232_helpers import wait_until

from tracker.emulator.easycomm_controller import EasycommOptions


@pytest.mark.parametrize("protocol", ["easycomm2", "easycomm3"])
def test_set_query_stop_on_the_wire(emulated_rig, protocol):
    rig = emulated_rig(protocol)
    with rig.driver() as d:
        assert d.raw(b"AZ120.0 EL30.0\n") == b""                 # a set is silent
        assert wait_until(lambda: rig.ctrl.antenna() == (120.0, 30.0))
        assert d.raw(b"AZ EL \n") == b"AZ120.0 EL30.0\n"
        assert d.raw(b"AZ\rEL\n") == b"AZ120.0\nEL30.0\n"         # one line, one answer
        assert d.raw(b"VE\n").startswith(b"VE")
        assert d.raw(b"XX YY\n") == b""                          # unknown: ignored
        d.goto(300, 80)
        assert wait_until(rig.ctrl.moving)
        d.stop()
        assert wait_until(lambda: not rig.ctrl.moving())
        held = rig.ctrl.antenna()
        assert held[0] < 300 and d.position() == (round(held[0], 1), round(held[1], 1))
    assert rig.tail_is(b"SA SE ")                                # exit: all-stop last


@pytest.mark.parametrize(("protocol", "moves"), [("easycomm3", True), ("easycomm2", False)])
def test_rate_moves_are_easycomm3_only(emulated_rig, protocol, moves):
    rig = emulated_rig(protocol)
    start = rig.ctrl.antenna()
    with rig.driver() as d:
        d.raw(b"VR4900\n", quiet_s=0.05)       # Hamlib 204's "M 16 50"
        assert rig.seen(b"VR4900")
        if moves:
            assert wait_until(lambda: rig.ctrl.antenna()[0] > start[0] + 1)
        else:
            assert rig.ctrl.antenna() == start and not rig.ctrl.moving()


def test_satnogs_stop_reply_is_left_unread(emulated_rig):
    """The SatNOGS firmware answers SA SE with the position; the next query still reads its
    own answer, not that stale line."""
    rig = emulated_rig("easycomm2", options=EasycommOptions(satnogs=True))
    with rig.driver() as d:
        d.goto(10, 10)
        assert wait_until(lambda: rig.ctrl.antenna() == (10.0, 10.0))
        d.stop()
        assert rig.seen(b"SA SE ")
        d.goto(20, 20)
        assert wait_until(lambda: rig.ctrl.antenna() == (20.0, 20.0))
        assert d.position() == (20.0, 20.0)
