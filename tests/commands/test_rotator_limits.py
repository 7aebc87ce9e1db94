"""``tracker rotator goto/park`` stay inside the effective limits and above the horizon mask.

The configured rotator (``--rotator`` / ``[tracking] rotator`` / G-5500) narrowed by what the
controller accepts, and the station's mask, decide; ``--ignore-limits`` is the loud
maintenance override. Moves go to the GS-232B emulator on a real TCP socket and the test
reads what the controller received.
"""

from __future__ import annotations

import pytest
from _gs232_helpers import wait_until

from tracker.cli import main
from tracker.clock import SystemClock
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.errors import LimitError
from tracker.mount import preset
from tracker.protocols.base import Capabilities
from tracker.session import EffectiveLimits, driver_limits
from tracker.station import HorizonMask, Station

# A G-5500 configured for 360 deg azimuth and 0-90 elevation.
CONFIG = """
[rotator.safe]
preset = "G-5500"
az_span_deg = 360
el_max_deg = 90

[rotator.parked]
preset = "G-5500"
park_az_deg = 180
park_el_deg = 5
"""
MASK = "0 10\n20 0\n340 0\n"     # 10 deg at north, falling to 0 at 20 and 340


@pytest.fixture
def files(tmp_path, monkeypatch):
    config = tmp_path / "safe.toml"
    config.write_text(CONFIG)
    mask = tmp_path / "north.mask"
    mask.write_text(MASK)
    monkeypatch.setenv("TRACKER_CONFIG", str(config))
    return config, mask


@pytest.fixture
def controller():
    ctrl = Gs232Controller("gs232b", preset("G-5500"), clock=SystemClock(), az_deg=180,
                           el_deg=5)
    with serve_tcp(ctrl) as server:
        yield ctrl, server.url


def _lines(ctrl) -> list[bytes]:
    return [line.strip() for _t, line, _r in ctrl.log]


def _moves(ctrl) -> list[bytes]:
    return [ln for ln in _lines(ctrl) if ln[:1] in (b"W", b"M")]


def _rotator(files, url, *argv, rotator="safe"):
    config, mask = files
    return main(["--config", str(config), "rotator", "--port", url, "--rotator", rotator,
                 "--mask", str(mask), *argv])


def _refused(rc, capsys, ctrl, needle):
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and "Traceback" not in err, err
    assert len([ln for ln in err.splitlines() if ln.startswith("tracker: error")]) == 1
    # A refusal ends the session with all-stop; nothing that moves went before it.
    assert wait_until(lambda: b"S" in _lines(ctrl), 3.0), _lines(ctrl)
    assert _moves(ctrl) == []
    return err


def test_goto_outside_the_configured_rotator_is_refused(files, controller, capsys):
    ctrl, url = controller
    err = _refused(_rotator(files, url, "goto", "400", "170"), capsys, ctrl, "azimuth 400")
    assert "az 0-360, el 0-90 (rotator safe)" in err


def test_goto_above_the_configured_elevation_is_refused(files, controller, capsys):
    ctrl, url = controller
    _refused(_rotator(files, url, "goto", "100", "170"), capsys, ctrl, "elevation 170")


def test_goto_below_the_mask_is_refused(files, controller, capsys):
    ctrl, url = controller
    err = _refused(_rotator(files, url, "goto", "0", "5"), capsys, ctrl, "horizon mask")
    assert "10 deg at bearing 0" in err


def test_goto_azimuth_alone_checks_the_mask_at_the_elevation_read_back(files, controller,
                                                                      capsys):
    ctrl, url = controller            # the antenna stands at el 5
    _refused(_rotator(files, url, "goto", "0"), capsys, ctrl, "horizon mask")


def test_goto_inside_the_limits_is_sent(files, controller, capsys):
    ctrl, url = controller
    assert _rotator(files, url, "goto", "200", "30") == 0, capsys.readouterr().err
    assert wait_until(lambda: b"W200 030" in _lines(ctrl), 3.0), _lines(ctrl)
    assert b"S" not in _lines(ctrl)          # a rotctl-like goto goes on after we exit


def test_park_goes_to_the_rotators_park_position(files, controller, capsys):
    ctrl, url = controller
    assert _rotator(files, url, "park", rotator="parked") == 0, capsys.readouterr().err
    assert wait_until(lambda: _moves(ctrl) == [b"W180 005"], 3.0), _lines(ctrl)


def test_park_is_raised_to_the_mask_like_after_a_pass(files, controller, capsys):
    ctrl, url = controller            # "safe" parks at 0/0, under the 10 deg at north
    assert _rotator(files, url, "park") == 0, capsys.readouterr().err
    assert wait_until(lambda: _moves(ctrl) == [b"W000 010"], 3.0), _lines(ctrl)


def test_park_override_below_the_mask_is_refused(files, controller, capsys):
    ctrl, url = controller
    _refused(_rotator(files, url, "--park-az", "0", "--park-el", "0", "park"), capsys, ctrl,
             "horizon mask")


def test_ignore_limits_sends_the_move_and_warns(files, controller, capsys):
    ctrl, url = controller
    assert _rotator(files, url, "--ignore-limits", "goto", "0", "5") == 0
    err = capsys.readouterr().err
    assert "warning: --ignore-limits" in err and "NOT checked" in err
    assert wait_until(lambda: _moves(ctrl) == [b"W000 005"], 3.0), _lines(ctrl)


def test_rotator_defaults_to_the_configured_tracking_rotator(tmp_path, controller, capsys,
                                                            monkeypatch):
    ctrl, url = controller
    config = tmp_path / "c.toml"
    config.write_text(CONFIG + '\n[tracking]\nrotator = "safe"\n')
    monkeypatch.setenv("TRACKER_CONFIG", str(config))
    rc = main(["rotator", "--port", url, "goto", "400", "10"])
    err = capsys.readouterr().err
    assert rc == 2 and "(rotator safe)" in err, err
    assert _moves(ctrl) == []


# Effective limits: the spec narrowed by what the controller reports -------------------------


def test_limits_narrowed_by_a_360_degree_controller():
    """GS-232B in P36 mode (or any driver reporting az_max_deg 360) narrows a G-5500."""
    lim = EffectiveLimits.of(preset("G-5500"), None, Capabilities(az_max_deg=360.0))
    lim.check_wire(359.0, 10.0)
    with pytest.raises(LimitError, match="controller takes azimuth up to 360"):
        lim.check_wire(400.0, 10.0)


def test_limits_narrowed_by_the_controllers_elevation_range():
    """rotctld's \\dump_caps 'Max Elevation 90' (the driver's el_max_deg) narrows 0-180."""
    lim = EffectiveLimits.of(preset("G-5500"), None, Capabilities(el_max_deg=90.0))
    lim.check_wire(100.0, 90.0)
    with pytest.raises(LimitError, match="elevation 120 is outside"):
        lim.check_wire(100.0, 120.0)


def test_limits_of_an_azimuth_only_controller_refuse_an_elevation():
    lim = EffectiveLimits.of(preset("G-5500"), None, Capabilities(has_elevation=False))
    lim.check_wire(100.0, None)
    with pytest.raises(LimitError, match="azimuth only"):
        lim.check_wire(100.0, 10.0)


def test_limits_check_the_mask_over_the_top_on_the_far_side():
    """el > 90 looks at bearing + 180: el 170 at az 180 looks north at 10 deg."""
    station = Station(mask=HorizonMask((0.0, 20.0, 340.0), (15.0, 0.0, 0.0)))
    lim = EffectiveLimits.of(preset("G-5500"), station)
    lim.check_wire(180.0, 160.0)                 # looks north at 20 deg: above 15
    with pytest.raises(LimitError, match="horizon mask"):
        lim.check_wire(180.0, 170.0)


def test_south_mapping_controller_takes_bearings_below_360():
    """A controller that maps its south-centred scale itself takes true bearings: its wire
    scale is 0-360 whatever the span (track and upload agree on it through driver_limits)."""
    spec = preset("G-5500").with_(stop_bearing_deg=180.0, controller_maps_south=True)
    assert driver_limits(spec)["az_max_deg"] == 360.0
    assert driver_limits(preset("G-5500"))["az_max_deg"] == 450.0
    lim = EffectiveLimits.of(spec)
    lim.check_wire(0.0, 10.0)
    with pytest.raises(LimitError):
        lim.check_wire(370.0, 10.0)


def test_planning_spec_is_narrowed_to_the_controller():
    g5500 = preset("G-5500")
    assert EffectiveLimits.of(g5500).rotator() is g5500          # nothing to narrow
    el90 = EffectiveLimits.of(g5500, None, Capabilities(el_max_deg=90.0)).rotator()
    assert (el90.el_max_deg, el90.az_span_deg) == (90.0, 450.0)
    p36 = EffectiveLimits.of(g5500.with_(park_az_deg=440.0), None,
                             Capabilities(az_max_deg=360.0)).rotator()
    assert (p36.az_span_deg, p36.park_az_deg, p36.el_max_deg) == (360.0, 360.0, 180.0)
    # A 0-359 scale (SAK-232) is a full turn for a 360 deg rotator: nothing to narrow.
    g400 = preset("G-400")
    assert EffectiveLimits.of(g400, None, Capabilities(has_elevation=False, az_max_deg=359.0)
                              ).rotator() is g400


def test_raw_is_refused_without_the_override(files, controller, capsys):
    """A raw line may be a move the guard cannot read: it needs the maintenance flag."""
    ctrl, url = controller
    rc = _rotator(files, url, "raw", "W400 170")
    err = capsys.readouterr().err
    assert rc == 2 and "--ignore-limits" in err and "Traceback" not in err, err
    assert err.count("\n") == 1
    assert _lines(ctrl) == []           # refused before the port was opened


def test_raw_with_the_override_is_sent_and_warns(files, controller, capsys):
    ctrl, url = controller
    assert _rotator(files, url, "--ignore-limits", "raw", "W400 170") == 0
    err = capsys.readouterr().err
    assert "NOT checked against the limits" in err, err
    assert wait_until(lambda: b"W400 170" in _lines(ctrl), 3.0), _lines(ctrl)
