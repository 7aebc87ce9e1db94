"""The live tracking loop (tracker.stream) drives each of the other controllers through its
driver: the Rotor-EZ and AZ/AZ closed loop on their read-back, the DCU-1 and SAK-232 open
loop on the motor-model estimate. Emulator (behind ``emu://``), loop and driver share one
virtual clock, so the pass runs in CPU time; the antenna's real azimuth must follow the
pass. The wire itself is the driver contract's subject (test_driver_contract.py)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from _stream_fakes import T0, arc_pass
from _virtual import manual_clock, newest_bench, virtual_rig

from tracker.emulator.factory import make_emulator
from tracker.mount import preset
from tracker.planner import plan_pass
from tracker.protocols import open_driver
from tracker.station import Station
from tracker.stream import Link, StreamSettings, TrackCore, run_pass

# The Rotor-EZ, DCU-1 and SAK-232 take true bearings (controller_maps_south); the AZ/AZ
# antenna-2 channel takes mechanical degrees like a GS-232.
BEARINGS = preset("G-400").with_(name="G-400-bearings", controller_maps_south=True,
                                 start_delay_s=0.0)
MECH = preset("G-400").with_(start_delay_s=0.0)
CASES = [("rotorez", "rotorez", BEARINGS, True), ("dcu1", "dcu1", BEARINGS, False),
         ("sak232", "sak232", BEARINGS, False), ("gs232b-azaz2", "gs232b-azaz", MECH, True)]


@pytest.mark.parametrize(("protocol", "emulator", "spec", "closed_loop"), CASES,
                         ids=[c[0] for c in CASES])
def test_stream_tracks_a_pass(protocol, emulator, spec, closed_loop):
    # bearings 30 -> 150: clear of the G-400's south stop (an az-only 360 deg rotator cannot
    # cross it, whatever the protocol)
    track = arc_pass(duration_s=100.0, az0_deg=30.0, az1_deg=130.0, pad_s=20.0)
    station = Station()
    plan = plan_pass(track, spec, station, current=(0.0, 0.0))
    start = min(plan.preposition_t_s, T0 - 25.0) - 2.0
    clock = manual_clock(start)
    ctrl = make_emulator(emulator, clock, spec, az_deg=None)
    server = virtual_rig(ctrl)
    errors: list[float] = []

    def bearing_now() -> float:
        a = ctrl.antenna()
        a = a[1] if isinstance(a, tuple) else a       # AZ/AZ: antenna 2
        return float(spec.bearing_of(a)) if not spec.controller_maps_south else float(a)

    def on_status(st):
        if T0 + 10 <= st.t_s <= T0 + 90:
            taz, _tel = track.direction_at(st.t_s)
            errors.append(abs((bearing_now() - float(taz) + 180.0) % 360.0 - 180.0))

    def connect():
        # open-loop drivers take the rotator spec for their motor-model estimate
        return open_driver(server.url, protocol, clock=clock, timeout_s=0.5,
                           **({} if closed_loop else {"spec": spec}))
    try:
        settings = StreamSettings(deadband_deg=4.0, park_after_pass=False)
        core = TrackCore(plan, track, spec, station, settings)
        result = run_pass(core, Link(connect, spec), clock, on_status=on_status)
    finally:
        server.close()
    # figures for the report (pytest -s): how well each loop kind follows in azimuth
    print(f"\n{protocol:14s} {'closed' if closed_loop else 'open'}-loop: {result.commands} "
          f"commands, azimuth error max {max(errors):.2f} mean {np.mean(errors):.2f} deg")
    assert result.completed and result.commands >= 4
    assert len(errors) > 20
    # the real antenna followed the pass in azimuth (deadband + one cycle of motion)
    assert float(np.max(errors)) < 8.0, (protocol, max(errors))



def test_tracker_track_cli_drives_a_rotor_ez(tmp_path, capsys, monkeypatch):
    """``tracker track --protocol rotorez --port emu://rotorez?rotator=G-400 --at ...``: a
    whole ISS pass on an azimuth-only G-400 behind an emulated Rotor-EZ, on the loop's
    virtual clock; all-stop at the end."""
    import json

    from tracker.cli import main

    cfg = tmp_path / "empty.toml"
    cfg.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(cfg))
    log = tmp_path / "track.jsonl"
    url = "emu://rotorez?rotator=G-400"
    rc = main(["track", "ISS (ZARYA)", "--port", url, "--protocol", "rotorez",
               "--rotator", "G-400", "--at", "2026-08-23T02:06:05Z", "--plain", "--log",
               str(log)])
    bench = newest_bench(url)
    bench.close()
    ctrl = bench.controller
    assert rc == 0, capsys.readouterr()
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
    replies = [r for r in recs if r["kind"] == "reply"]
    assert len(gotos) >= 5 and len(replies) > 20
    cmds = [c for _t, c, _r in ctrl.log]
    # every byte written (the controller's own log keeps only the last 200 commands)
    assert bench.bytes_written().count(b"AP1") == len(gotos)
    assert cmds[-1] == b";" and bench.bytes_written().endswith(b";")   # all-stop last
    assert b"AI1;" in cmds
    # An azimuth-only rotator is judged on azimuth, as its plan is: the pass's elevation is
    # not an error the tracker could have avoided.
    plan = next(r for r in recs if r["kind"] == "state" and r.get("state") == "plan")
    done = next(r for r in recs if r["kind"] == "state" and r.get("state") == "pass_done")
    deadband = float(re.search(r"deadband ([\d.]+)\)", capsys.readouterr().out).group(1))
    assert done["max_error_deg"] <= plan["predicted_max_error_deg"] + deadband, done


@pytest.mark.parametrize("protocol", ["rotorez", "dcu1", "sak232", "gs232b-azaz2"])
def test_tracker_track_demo_serves_the_protocols_own_emulator(tmp_path, capsys, monkeypatch,
                                                              protocol):
    """``tracker track --protocol X`` without ``--port``: the simulated pass runs on X's own
    emulator and rotator (not the GS-232B one), and an open-loop protocol says that the
    antenna shown is the motor model's estimate."""
    import json

    from tracker.cli import main

    cfg = tmp_path / "empty.toml"
    cfg.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(cfg))
    log = tmp_path / "track.jsonl"
    rc = main(["track", "ISS (ZARYA)", "--protocol", protocol, "--at",
               "2026-08-23T02:06:05Z", "--speed", "max", "--plain", "--log", str(log)])
    out, err = capsys.readouterr()
    assert rc == 0, err
    emulator = "gs232b-azaz" if protocol == "gs232b-azaz2" else protocol
    assert f"SIMULATION: built-in {emulator} emulator" in out
    open_loop = "no position query: tracking open loop" in out
    assert open_loop == (protocol in ("dcu1", "sak232")), out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
    assert len(gotos) >= 5
    assert any(r["kind"] == "state" and r.get("state") == "pass_done" for r in recs)


def test_tracker_track_rotctld_needs_a_port(tmp_path, capsys, monkeypatch):
    from tracker.cli import main

    cfg = tmp_path / "empty.toml"
    cfg.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(cfg))
    rc = main(["track", "ISS (ZARYA)", "--protocol", "rotctld"])
    _out, err = capsys.readouterr()
    assert rc == 2 and err.startswith("tracker: error:") and "--port" in err
    assert len(err.strip().splitlines()) == 1
