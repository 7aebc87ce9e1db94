"""``tracker station run`` end to end.

A simulated stretch in-process (virtual time); a real station as a real process in front of
an emulated GS-232B on a real TCP socket, with its status page read over HTTP and its control
port driven by Hamlib's ``rotctl -m 2``, ended with SIGTERM (all-stop last, exit 0); SIGHUP
reloading the config of a running simulation; and bad input (one line, exit 2).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import urllib.request

import pytest
from _gs232_helpers import WAIT_S, wait_until
from _rigs import ROTCTL, EmulatedRig, default_signals, free_port, rotctl

from tracker.cli import main

CONFIG = """\
[station]
name = "home"
lat_deg = 52.0
lon_deg = 4.4

[schedule]
targets = {targets}
"""


def _config(folder, targets: str = '{ "NOAA 20" = 1 }', extra: str = ""):
    path = folder / "config.toml"
    path.write_text(CONFIG.format(targets=targets) + extra)
    return path


def test_a_simulated_stretch_tracks_and_reports(isolated_home, capsys):
    log = isolated_home / "passes.jsonl"
    code = main(["station", "run", "--simulate", "--speed", "max", "--hours", "0.6",
                 "--at", "2026-08-22T12:50:00Z", "--config", str(_config(isolated_home)),
                 "--pass-log", str(log), "--plot", str(isolated_home / "day.png")])
    out = capsys.readouterr().out
    assert code == 0
    assert (isolated_home / "day.png").read_bytes().startswith(b"\x89PNG")
    assert out.startswith("SIMULATION: built-in gs232b emulator with a G-5500")
    assert re.search(r"passes: 1 scheduled, 1 tracked, 0 skipped, 0 failed", out)
    assert "NOAA 20 (JPSS-1)" in out.split("station report")[1]
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert [r["outcome"] for r in records if r["chosen"]] == ["done"]


@pytest.mark.parametrize("argv, words", [
    (["--speed", "10"], "--speed needs --simulate"),
    (["--simulate", "--hours", "0"], "--hours 0 is invalid"),
    (["--simulate", "--speed", "1e-300"], "1e-300 is invalid; use a number from 0.01"),
    (["--simulate", "--speed", "nan"], "nan is invalid"),
    (["--simulate", "--control-port", "4533"], "--control-port needs a real controller"),
    (["--simulate", "--status-port", "70000"], "--status-port 70000 is invalid"),
    (["--simulate", "--protocol", "rotctld"], "has no built-in emulator"),
    ([], "no [schedule] section"),
])
def test_bad_input_is_one_line_and_exit_2(isolated_home, capsys, argv, words):
    assert main(["station", "run", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err


@pytest.mark.parametrize("targets, argv, words", [
    ('{ "NOSUCHSAT" = 1 }', [], "[schedule] targets: no satellite 'NOSUCHSAT'"),
    ('{ "NOAA 20" = 1 }', ["--at", "1900-01-01"], "only usable within 730 days"),
    ('{ "NOAA 20" = 1 }', ["--status-port", "8", "--listen", "garbage!!"],
     "cannot listen on garbage!!:8 (not an address"),
])
def test_a_simulation_that_cannot_start_is_one_line_and_exit_2(isolated_home, capsys,
                                                              targets, argv, words):
    config = _config(isolated_home, targets)
    assert main(["station", "run", "--simulate", "--speed", "max", "--hours", "0.5", "--at",
                 "2026-08-22T12:50:00Z", "--config", str(config), *argv]) == 2  # last --at wins
    err = [line for line in capsys.readouterr().err.splitlines()
           if not line.startswith("tracker: note:")]
    assert len(err) == 1 and words in err[0], err


def test_a_second_sigterm_while_the_station_shuts_down_does_not_kill_it(isolated_home, capsys,
                                                                       monkeypatch):
    import tracker.service.simulate as simulate
    from tracker.service.runner import StationService

    def run_until_sigterm(self, until_s=None):
        signal.raise_signal(signal.SIGTERM)       # the session's handler: all-stop, then out
        raise AssertionError("SIGTERM did not interrupt the run")

    handlers_at_close: list = []
    emulated = simulate.emulated

    def watched(*args, **kw):
        bench, connect = emulated(*args, **kw)
        close = bench.close

        def close_and_note() -> None:
            handlers_at_close.append(signal.getsignal(signal.SIGTERM))
            close()
        bench.close = close_and_note
        return bench, connect

    monkeypatch.setattr(StationService, "run", run_until_sigterm)
    monkeypatch.setattr(simulate, "emulated", watched)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["station", "run", "--simulate", "--speed", "max", "--hours", "0.5", "--at",
                 "2026-08-22T12:50:00Z", "--config", str(_config(isolated_home))]) == 0
    out = capsys.readouterr().out
    assert "SIGTERM: stopping the rotator" in out and "station report" in out
    # while it closed up, a second SIGTERM would not have been the default (kill)
    assert handlers_at_close and handlers_at_close[0] not in (signal.SIG_DFL, before)
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_second_run_on_the_same_state_file_is_refused_before_it_sends_anything(
        isolated_home, capsys):
    from tracker.service.records import state_lock

    state = isolated_home / "state.json"
    with state_lock(state):                       # the first run holds it
        assert main(["station", "run", "--simulate", "--speed", "max", "--hours", "0.5",
                     "--at", "2026-08-22T12:50:00Z", "--config", str(_config(isolated_home)),
                     "--state", str(state)]) == 2
    out, err = capsys.readouterr()
    assert "is in use by another station run" in err and "station report" not in out


def test_a_state_path_that_is_a_folder_is_refused(isolated_home, capsys):
    config = _config(isolated_home)
    assert main(["station", "run", "--port", "socket://127.0.0.1:9", "--config", str(config),
                 "--state", str(isolated_home)]) == 2
    assert "is not a regular file" in capsys.readouterr().err


# Generous: a loaded machine is slow, never wrong.
LINE_WAIT_S = 180.0


class _StationProcess:
    """``tracker station run ARGS`` as a real process; :meth:`wait_for` reads its lines."""

    def __init__(self, *args: str, env: dict | None = None):
        self.proc = subprocess.Popen([sys.executable, "-m", "tracker", "station", "run", *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env=env, preexec_fn=default_signals())
        self.lines: list[str] = []

    def wait_for(self, part: str) -> str:
        """Read lines until one holds ``part`` (the process's own pace; EOF fails). A process
        that says nothing of the kind for :data:`LINE_WAIT_S` is killed: a failure, never a
        hang."""
        watchdog = threading.Timer(LINE_WAIT_S, self.proc.kill)
        watchdog.start()
        try:
            while True:
                line = self.proc.stdout.readline()
                if not line:
                    raise AssertionError(f"no line with {part!r}; got {self.lines[-20:]} "
                                         f"{self.proc.stderr.read()[-2000:]}")
                self.lines.append(line)
                if part in line:
                    return line
        finally:
            watchdog.cancel()

    def stop(self, sig: int = signal.SIGTERM) -> tuple[int, str, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            out, err = self.proc.communicate(timeout=WAIT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
        return self.proc.returncode, "".join(self.lines) + out, err


@pytest.mark.skipif(ROTCTL is None, reason="Hamlib rotctl not installed")
def test_a_station_hands_the_rotator_to_rotctl_shows_its_page_and_stops_on_sigterm(
        isolated_home):
    pytest.importorskip("flask")
    rig = EmulatedRig("gs232b", "tcp")
    status_port, control_port = free_port(), free_port()
    env = {**os.environ, "TRACKER_CELESTRAK_URL": "http://127.0.0.1:9/"}
    # on the real clock a pass may be due any time: one that never comes keeps it idle
    config = _config(isolated_home, extra="min_max_el_deg = 89.9\n")
    station = _StationProcess(
        "--port", rig.url, "--protocol", "gs232b", "--config", str(config),
        "--state", str(isolated_home / "state.json"), "--status-port", str(status_port),
        "--control-port", str(control_port), env=env)
    try:
        station.wait_for("control port (rotctld protocol)")
        where = f"127.0.0.1:{control_port}"
        # the first schedule is built before the hand-over: seconds on a loaded machine
        assert wait_until(lambda: _status(status_port)["state"] == "handed_over", 120.0)
        rotctl("2", where, "P", "100", "30")
        assert rig.seen(b"W100 030")
        status = _status(status_port)
        assert status["control_port"]["owner"] == "outside"
        assert status["station"]["name"] == "home" and status["simulated"] is False
        assert any("element" in f["text"] for f in status["faults"])   # offline refresh
    finally:
        code, out, err = station.stop()
        rig.close()
    assert code == 0, err
    assert rig.tail_is(b"S")                             # all-stop was the last command
    assert "SIGTERM: stopping the rotator" in out and "all-stop sent" in out
    assert "station report" in out


def _status(port: int) -> dict:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/status", timeout=10) as r:
        return json.loads(r.read())


def test_sighup_reloads_the_config_between_passes_and_sigterm_ends_cleanly(isolated_home):
    config = _config(isolated_home)
    station = _StationProcess("--simulate", "--speed", "3000", "--hours", "24", "--at",
                              "2026-08-22T12:00:00Z", "--config", str(config))
    try:
        station.wait_for("schedule (start)")
        config.write_text(CONFIG.format(targets='{ "NOAA 20" = 1, "FUNCUBE-1" = 2 }'))
        station.proc.send_signal(signal.SIGHUP)
        station.wait_for("schedule (configuration reloaded)")
        line = station.wait_for("pass of ")
    finally:
        code, out, err = station.stop()
    assert code == 0, err
    assert "reloading the configuration (SIGHUP)" in out
    assert "NOAA 20 (JPSS-1)" in line or "FUNCUBE-1" in line
    assert "all-stop sent; the station is stopped" in out and "station report" in out


def test_the_systemd_unit_runs_the_station_reloads_with_sighup_and_stops_with_sigterm():
    import configparser
    import shlex
    from pathlib import Path

    unit = configparser.ConfigParser(interpolation=None, strict=False)
    unit.read(Path(__file__).resolve().parents[2] / "examples" / "tracker-station.service")
    service = unit["Service"]
    argv = shlex.split(service["ExecStart"])
    assert Path(argv[0]).name == "tracker" and argv[1:3] == ["station", "run"]
    from tracker.cli import build_parser

    args = build_parser(argv[1:]).parse_args(argv[1:])    # the unit's flags are the CLI's
    assert args.func.__module__ == "tracker.commands.station"
    assert "-HUP" in service["ExecReload"] and service["KillSignal"] == "SIGTERM"
    assert service["Restart"] == "on-failure"
