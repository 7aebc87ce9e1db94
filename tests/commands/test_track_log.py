"""``tracker track --log``: a log that cannot be opened ends the run before anything moves;
a log that cannot be written (full disk, file size limit) never stops tracking."""

from __future__ import annotations

import io
import os
import resource
import subprocess
import sys
from datetime import datetime, timezone

import pytest
from _paths import REPO

from tracker.cli import main
from tracker.clock import ManualClock, SimClock
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.errors import ConfigError
from tracker.mount import preset
from tracker.trackui import JsonLinesLog

AT = "2026-08-23T02:05:00Z"      # a pass of ISS over the default station (AOS ~02:07:45)


def _config(folder) -> str:
    path = os.path.join(str(folder), "empty.toml")
    with open(path, "w") as fh:
        fh.write("")
    return path


@pytest.fixture
def emulator():
    clock = SimClock(datetime(2026, 8, 23, 2, 5, tzinfo=timezone.utc), 150.0)
    ctl = Gs232Controller("gs232b", preset("G-5500"), clock=clock)
    server = serve_tcp(ctl)
    try:
        yield ctl, server.url
    finally:
        server.close()


def _one_error_line(err: str) -> str:
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("tracker: error:")]
    assert len(lines) == 1, err     # notes (e.g. the default station) may come before it
    return lines[0]


@pytest.mark.parametrize("where, needle", [
    ("missing/track.jsonl", "does not exist"),
    (".", "is a directory"),
])
def test_log_path_that_cannot_be_opened_is_one_line_and_nothing_moves(
        where, needle, emulator, tmp_path, capsys, monkeypatch):
    ctl, url = emulator
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    rc = main(["track", "ISS (ZARYA)", "--port", url, "--at", AT, "--speed", "150",
               "--plain", "--log", str(tmp_path / where)])
    assert rc == 2
    assert needle in _one_error_line(capsys.readouterr().err)
    assert ctl.log == []          # not a byte reached the controller


def test_log_fifo_nobody_reads_is_refused_not_a_hang(emulator, tmp_path, capsys, monkeypatch):
    ctl, url = emulator
    fifo = tmp_path / "pipe.jsonl"
    os.mkfifo(fifo)
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    rc = main(["track", "ISS (ZARYA)", "--port", url, "--at", AT, "--plain", "--log", str(fifo)])
    assert rc == 2
    assert "cannot open it for writing" in _one_error_line(capsys.readouterr().err)
    assert ctl.log == []


def _unwritable_path(tmp_path) -> str:
    """A log path this process may not create: a read-only folder, or for root (who may
    write anywhere on a normal file system) a file in sysfs."""
    if os.geteuid() != 0:
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        return str(ro / "track.jsonl")
    path = "/sys/tracker-test-log.jsonl"
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT, 0o644))
    except PermissionError:
        return path
    pytest.skip("no path this root process is refused")


def test_unwritable_log_path_is_one_line_and_nothing_moves(emulator, tmp_path, capsys,
                                                           monkeypatch):
    ctl, url = emulator
    monkeypatch.setenv("TRACKER_CONFIG", _config(tmp_path))
    rc = main(["track", "ISS (ZARYA)", "--port", url, "--at", AT, "--plain",
               "--log", _unwritable_path(tmp_path)])
    assert rc == 2
    assert "permission denied" in _one_error_line(capsys.readouterr().err)
    assert ctl.log == []


def _run_demo_pass(log: str, tmp_path, preexec=None) -> subprocess.CompletedProcess:
    env = dict(os.environ, TRACKER_CONFIG=_config(tmp_path), PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, "-m", "tracker", "track", "ISS (ZARYA)", "--at", AT, "--speed", "150",
         "--plain", "--log", log],
        capture_output=True, text=True, env=env, timeout=300, preexec_fn=preexec)


def _warned_once_and_tracked(proc: subprocess.CompletedProcess) -> None:
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    warnings = [ln for ln in proc.stderr.splitlines() if "cannot write the log" in ln]
    assert len(warnings) == 1, proc.stderr
    assert "tracking goes on" in warnings[0]
    # the whole pass ran after the failure: parked and reported
    assert "pass 1:" in proc.stdout and "commands sent" in proc.stdout


def test_full_disk_log_warns_once_and_the_pass_completes(tmp_path):
    _warned_once_and_tracked(_run_demo_pass("/dev/full", tmp_path))


def test_log_that_cannot_grow_warns_once_and_the_pass_completes(tmp_path):
    limit = 2000

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    log = tmp_path / "track.jsonl"
    proc = _run_demo_pass(str(log), tmp_path, preexec=small_files)
    _warned_once_and_tracked(proc)
    assert 0 < log.stat().st_size <= limit
    # only whole lines: the line that did not fit was not half written
    text = log.read_text()
    assert text.endswith("\n")


def test_log_write_failure_closes_the_log_and_warns_once():
    warn = io.StringIO()
    log = JsonLinesLog("/dev/full", ManualClock(datetime(2026, 1, 1, tzinfo=timezone.utc)),
                       warn_stream=warn)
    for _ in range(3):
        log.event("command", cmd="goto", az=10.0)
    log.close()
    assert warn.getvalue().count("cannot write the log /dev/full") == 1


def test_log_open_errors_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="is a directory"):
        JsonLinesLog(tmp_path, ManualClock(datetime(2026, 1, 1, tzinfo=timezone.utc)))
