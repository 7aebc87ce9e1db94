"""Shared fixtures: an emulated rig on a real pty or TCP socket (with the leak check), and
``tracker emulate`` as a real subprocess stopped with SIGTERM.

Time: every wait in the tests polls a condition for at most ``_gs232_helpers.WAIT_S``, the one
generous bound of the suite (a busy machine makes a test slower, never wrong); the simulated
motors of the real-I/O tier run at ``_gs232_helpers.SPEED`` unless the rate is the subject.
"""

from __future__ import annotations

import pytest
from _gs232_helpers import SPEED
from _rigs import EmulatedRig, EmulateProcess


@pytest.fixture(params=["pty", "tcp"])
def transport(request) -> str:
    return request.param


@pytest.fixture
def emulated_rig(transport):
    """``emulated_rig(protocol, speed=SPEED, **controller_kw)`` -> :class:`EmulatedRig` on
    this test's transport; every rig is closed and leak-checked afterwards."""
    made: list[EmulatedRig] = []

    def make(protocol: str, speed: float = SPEED, **ctrl_kw) -> EmulatedRig:
        rig = EmulatedRig(protocol, transport, speed, **ctrl_kw)
        made.append(rig)
        return rig
    yield make
    for rig in made:
        rig.close()
    for rig in made:
        rig.assert_released()


@pytest.fixture
def emulate():
    """``emulate(*args)`` starts ``tracker emulate *args``; whatever a test leaves running is
    stopped with SIGTERM at the end."""
    made: list[EmulateProcess] = []

    def start(*args: str, url_now: bool = True, **popen_kw) -> EmulateProcess:
        p = EmulateProcess(*args, url_now=url_now, **popen_kw)
        made.append(p)
        return p
    yield start
    for p in made:
        if p.returncode is None:
            p.stop()


@pytest.fixture
def celestrak():
    """A fake CelesTrak on 127.0.0.1 serving the bundled groups (``tests/_celestrak.py``)."""
    from _celestrak import FakeCelestrak

    fake = FakeCelestrak()
    yield fake
    fake.close()
