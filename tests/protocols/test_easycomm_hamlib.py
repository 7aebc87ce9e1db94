"""Hamlib's rotctl (Easycomm II model 202, Easycomm III model 204) against
``tracker emulate --protocol easycommN --pty`` as a real process: set, read back, stop."""

from __future__ import annotations

import pytest
from _gs232_helpers import WAIT_S, wait_until
from _rigs import require_rotctl
from _rigs import rotctl as run_rotctl

pytestmark = pytest.mark.hamlib

require_rotctl()


def rotctl(model: str, url: str, *cmds: str) -> str:
    return run_rotctl(model, url, *cmds).stdout


@pytest.mark.parametrize(("model", "protocol"), [("202", "easycomm2"), ("204", "easycomm3")])
def test_rotctl_set_read_back_stop(emulate, model, protocol):
    p = emulate("--protocol", protocol, "--pty", "--speed", "5", "--az", "100", "--el", "20")
    rotctl(model, p.url, "P", "120", "30")

    def there() -> bool:
        az, el = (float(v) for v in rotctl(model, p.url, "p").split()[:2])
        return (az, el) == (120.0, 30.0)
    assert wait_until(there, WAIT_S)
    rotctl(model, p.url, "P", "350", "170")
    rotctl(model, p.url, "S")
    first = rotctl(model, p.url, "p").split()[:2]
    assert wait_until(lambda: rotctl(model, p.url, "p").split()[:2] == first, WAIT_S)
    az, el = (float(v) for v in first)
    assert az < 350 and el < 170                      # stopped short of the target
    rc, _out, err = p.stop()
    assert rc == 0 and err == "", err
