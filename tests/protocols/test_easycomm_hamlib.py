"""Hamlib's rotctl (Easycomm II model 202, Easycomm III model 204) against
``tracker emulate --protocol easycommN --pty`` as a real process: set, read back, stop."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from _gs232_helpers import WAIT_S, wait_until

pytestmark = pytest.mark.hamlib

ROTCTL = shutil.which("rotctl")
if ROTCTL is None:
    pytest.skip("Hamlib rotctl not installed (apt install libhamlib-utils)",
                allow_module_level=True)


def rotctl(model: str, url: str, *cmds: str) -> str:
    r = subprocess.run([ROTCTL, "-m", model, "-r", url, *cmds], capture_output=True,
                       text=True, timeout=20)
    assert r.returncode == 0, f"rotctl -m {model} {cmds} failed: {r.stdout} {r.stderr}"
    return r.stdout


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
