"""``tracker track`` from the command line: the demo, errors, and Ctrl-C over a real socket."""

from __future__ import annotations

import itertools
import json
import os
import re
import signal
import subprocess
import sys
import time
from datetime import datetime, timezone

import pytest
from _rigs import default_signals
from _virtual import newest_bench

from tracker.cli import main
from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.mount import preset

# A pass of ISS (ZARYA) over the default station with the bundled elements: AOS ~02:07:45.
AT = "2026-08-23T02:05:00Z"


def _config(tmp_path) -> str:
    """An empty config file: the default station and rotator, never the user's own."""
    path = tmp_path / "empty.toml"
    path.write_text("")
    return str(path)


def _env(tmp_path):
    env = dict(os.environ)
    env["TRACKER_CONFIG"] = _config(tmp_path)
    return env


def test_demo_runs_a_whole_pass_on_the_builtin_emulator(tmp_path, capsys, monkeypatch):
    # --speed max: the demo on virtual time (no waiting), so the bounds below are exact
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    log = tmp_path / "track.jsonl"
    rc = main(["track", "ISS (ZARYA)", "--at", AT, "--speed", "max", "--plain",
               "--log", str(log)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "SIMULATION" in out and "emulator" in out and "virtual time" in out
    assert "pass 1:" in out and "commands sent" in out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    kinds = {r["kind"] for r in recs}
    assert {"command", "reply", "state"} <= kinds
    assert next(r for r in recs if r.get("state") == "start")["speed"] == "max"   # valid JSON
    gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
    assert gotos[0]["reason"] == "preposition" and gotos[-1]["reason"] == "park"
    done = next(r for r in recs if r.get("state") == "pass_done")
    assert done["commands"] == len(gotos)
    plan = next(r for r in recs if r.get("state") == "plan")
    deadband = float(re.search(r"deadband ([\d.]+)\)", out).group(1))
    assert done["max_error_deg"] <= plan["predicted_max_error_deg"] + deadband, (done, plan)
    assert all(r["t"].endswith("Z") for r in recs)


def test_demo_at_a_speed_factor_still_runs_on_a_simulated_clock(tmp_path, capsys, monkeypatch):
    """The demo users watch: a SimClock (paused while planning, idle time skipped) driving
    the in-process emulator. Only the outcome is checked: its timing is the wall clock's."""
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    log = tmp_path / "track.jsonl"
    rc = main(["track", "ISS (ZARYA)", "--at", AT, "--speed", "1000", "--plain", "--log",
               str(log)])
    out = capsys.readouterr().out
    assert rc == 0 and "at 1000x speed" in out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    assert next(r for r in recs if r.get("state") == "start")["speed"] == 1000.0
    assert any(r.get("state") == "pass_done" for r in recs)
    assert any(r["kind"] == "command" and r["cmd"] == "stop" for r in recs)   # all-stop


def test_track_on_an_emu_port_runs_the_pass_on_virtual_time(tmp_path, capsys, monkeypatch):
    """--port emu://PROFILE with --at: an in-process controller on the loop's virtual clock
    (no pty, no socket); all-stop is the last thing written."""

    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    log = tmp_path / "track.jsonl"
    url = "emu://gs232b?rotator=G-5500"
    rc = main(["track", "ISS (ZARYA)", "--port", url, "--at", AT, "--plain", "--log",
               str(log)])
    out = capsys.readouterr().out
    assert rc == 0 and "pass 1:" in out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    plan = next(r for r in recs if r.get("state") == "plan")
    done = next(r for r in recs if r.get("state") == "pass_done")
    deadband = float(re.search(r"deadband ([\d.]+)\)", out).group(1))
    assert done["max_error_deg"] <= plan["predicted_max_error_deg"] + deadband, (done, plan)
    bench = newest_bench(url)
    try:
        assert bench.bytes_written().endswith(b"S\r")
        lines = bench.bytes_written().split(b"\r")
        gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
        assert sum(ln.startswith(b"W") for ln in lines) == len(gotos) >= 5
    finally:
        bench.close()


def test_rotator_position_on_an_emu_port(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    assert main(["rotator", "--port", "emu://gs232b?az=123&el=45", "position"]) == 0
    assert capsys.readouterr().out.split() == ["123", "45"]


def test_unknown_emu_profile_is_one_line_and_exit_2(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    assert main(["rotator", "--port", "emu://nosuch", "position"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error:") and "nosuch" in err and "gs232b" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv, needle", [
    (["track", "NO SUCH SATELLITE 12345", "--at", AT], "NO SUCH SATELLITE"),
    (["track", "ISS (ZARYA)", "--at", AT, "--deadband", "99"], "--deadband"),
    (["track", "ISS (ZARYA)", "--port", "/dev/does-not-exist-h8"], "does-not-exist"),
])
def test_bad_input_is_one_line_and_exit_2(argv, needle, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2
    lines = [ln for ln in err.splitlines() if ln.startswith("tracker: error:")]
    assert len(lines) == 1 and needle in lines[0]
    assert "Traceback" not in err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_mid_pass_sends_all_stop_last(sig, tmp_path):
    speed = 20.0
    at = "2026-08-23T02:06:05Z"   # the pre-position starts a few simulated seconds later
    clock = SimClock(datetime(2026, 8, 23, 2, 6, 5, tzinfo=timezone.utc), speed)
    ctl = Gs232Controller("gs232b", preset("G-5500"), clock=clock)
    server = serve_tcp(ctl)
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "tracker", "track", "ISS (ZARYA)", "--port", server.url,
             "--at", at, "--speed", str(speed), "--plain"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env(tmp_path), text=True,
            preexec_fn=default_signals())
        deadline = time.monotonic() + 40
        while time.monotonic() < deadline and not ctl.moving():
            time.sleep(0.05)   # wait until the tracker has the antenna turning
        assert ctl.moving(), "the tracker never moved the antenna"
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=20)
        assert proc.returncode == 130, (out, err)
        assert "Traceback" not in err
        deadline = time.monotonic() + 2.0   # the emulator thread may still be reading
        while time.monotonic() < deadline and ctl.log[-1][1].strip() != b"S":
            time.sleep(0.01)
        lines = [ln.strip() for _t, ln, _r in ctl.log]
        assert lines[-1] == b"S", lines[-5:]
        assert not ctl.moving()
    finally:
        server.close()


def test_demo_lines_speak_plainly(tmp_path, capsys, monkeypatch):
    """No internal state names, the mode said once, no p99; the waiting screen's target
    moves; no pointing error once the pass is over."""
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    assert main(["track", "ISS (ZARYA)", "--at", "2026-08-23T02:03:00Z", "--speed", "max",
                 "--plain"]) == 0
    out = capsys.readouterr().out
    for word in ("state ", "pass_done", "p99", "mode normal: Normal"):
        assert word not in out, word
    assert "mode normal: the pass stays" in out
    waiting = [line.split("target az")[1].split("antenna")[0] for line in out.splitlines()
               if "  wait  " in line]
    assert len(waiting) >= 3 and len(set(waiting)) == len(waiting), waiting
    done = next(line for line in out.splitlines() if "  done  " in line)
    assert "error    -" in done


def test_dcu1_demo_explains_its_error_and_never_repeats_a_move(tmp_path, capsys, monkeypatch):
    """An open-loop DCU-1 on a south-stop HAM-IV: the unwind goes to one step short of the
    stop's bearing (the controller takes the stop's own bearing as the CCW end), so no move
    is sent again and again; the azimuth error is said to be one, and why it is large."""
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    log = tmp_path / "track.jsonl"
    assert main(["track", "ISS (ZARYA)", "--at", AT, "--speed", "max", "--plain",
                 "--protocol", "dcu1", "--log", str(log)]) == 0
    out = capsys.readouterr().out
    assert "None" not in out
    assert "max azimuth error" in out and "unwinds once" in out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    assert not [r for r in recs if r.get("state") == "contradiction"]
    gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
    for a, b in itertools.pairwise(gotos):
        assert not (a["az"] == b["az"] and b["t_s"] - a["t_s"] < 3.0), (a, b)
    assert max(r["az_m"] for r in gotos) < 360.0
