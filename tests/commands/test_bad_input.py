"""Every bad input of the abuse run, as ``tracker ...``: one line ``tracker: error: ...``, exit 2.

One table, one row per case. Most rows run ``tracker.cli.main`` in-process (cheap); rows that
could block or eat memory on a regression (FIFOs, ``/dev/zero``) run as a subprocess with a
timeout and, for ``/dev/zero``, a memory limit. A few rows have another documented outcome
(a UTF-8 BOM config is accepted; ``next`` with no pass in the window exits 1 with one line on
stdout, as grep does when it finds nothing).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from _paths import DATA, REPO

from tracker.cli import main

SATS = str(DATA / "passes_sats.tle")
AT = "2026-08-23T00:00:00Z"         # a day after the elements' epoch
HERE = ["--lat", "52.0", "--lon", "4.4", "--alt", "10"]
EMU_PORT = "socket://127.0.0.1:1"   # never reached: the argument checks come first

ERROR = "error"     # one stderr line starting "tracker: error:", exit 2


@dataclass(frozen=True)
class Case:
    id: str
    argv: tuple[str, ...]
    says: str = ""               # a piece of the one error line (or of stdout for outcomes)
    outcome: str = ERROR         # ERROR, "ok" (exit 0), "no-pass" (exit 1, one stdout line)
    subprocess: bool = False     # may block/grow without bound on a regression
    memory_limit: bool = False   # run under RLIMIT_AS


def c(id_: str, *argv: str, **kw) -> Case:
    return Case(id_, tuple(argv), **kw)


CASES = [
    # -- command lines argparse refuses: the same one line, naming the help to read
    c("args-bad-float", "next", "ISS (ZARYA)", "--days", "abc", says="(see 'tracker next --help')"),
    c("args-unknown-command", "nope", says="invalid choice: 'nope'"),
    c("args-no-command", says="give a command: batch, config"),
    c("args-missing", "rotator", "--port", "emu://gs232b", says="required: ACTION"),
    # -- TOML nested past the parser's recursion limit
    c("nested-config", "config", "show", "--config", "{nested_toml}", says="nested too deeply"),
    c("nested-stations", "batch", "amateur", "--stations", "{nested_toml}",
      says="nested too deeply"),
    c("emu-nan", "rotator", "--port", "emu://gs232b?az=nan", "position",
      says="az nan is outside the G-5500 travel"),
    c("url-bad-ipv6", "tle", "update", "http://[::1", says="not a valid URL"),
    # -- numbers no run can use
    c("emulate-speed-huge", "emulate", "--speed", "1e300", "--duration", "0.1",
      says="--speed 1e+300 is invalid"),
    c("emulate-duration-huge", "emulate", "--duration", "1e300", says="--duration 1e+300"),
    c("rotator-timeout-huge", "rotator", "--port", "emu://gs232b", "--timeout", "1e300",
      "position", says="--timeout 1e+300 is invalid"),
    c("upload-max-error-inf", "upload", "ISS", "--tle", SATS, *HERE, "--dry-run",
      "--max-error", "inf", says="--max-error inf is invalid"),
    c("upload-speed-inf", "upload", "ISS", "--tle", SATS, *HERE, "--at",
      "2026-08-23T02:00:00Z", "--speed", "inf", says="--speed: inf is invalid"),
    c("sync-fraction", "rotator", "--port", "emu://gs232b-azaz", "--protocol", "gs232b-azaz",
      "sync", "1.5", says="whole degrees"),
    # -- an empty value is a script that lost a variable (--bind '' would mean every interface)
    c("empty-port", "track", "ISS (ZARYA)", "--port", "", says="--port is empty"),
    c("empty-bind", "emulate", "--tcp", "0", "--bind", "", says="--bind is empty"),
    c("empty-from", "upload", "--dry-run", "--from", "", says="--from is empty"),
    c("empty-target", "next", "", says="target is empty"),
    c("empty-tle", "passes", "ISS", "--tle", SATS, "--tle", "", says="--tle is empty"),
    # -- 12: special files: refused at once, never read without bound
    *[c(f"fifo-{flag}", *pre, "{fifo}", *post, says="FIFO", subprocess=True)
      for flag, pre, post in (
          ("tle", ("passes", "ISS", "--at", AT, *HERE, "--tle"), ()),
          ("mask", ("passes", "ISS", "--at", AT, "--tle", SATS, *HERE, "--mask"), ()),
          ("config", ("passes", "ISS", "--at", AT, "--tle", SATS, "--config"), ()),
          ("priorities", ("schedule", SATS, "--at", AT, *HERE, "--priorities"), ()),
          ("upload-from", ("upload", "--from"), ()),
          ("upload-from-dry-run", ("upload", "--dry-run", "--from"), ()),
          ("tle-show", ("tle", "show", "ISS", "--tle"), ()),
          ("batch-catalog", ("batch",), ("--at", AT, *HERE)),
          ("batch-stations", ("batch", SATS, "--at", AT, "--stations"), ()),
      )],
    *[c(f"dev-zero-{flag}", *argv, says="character device", subprocess=True,
        memory_limit=True)
      for flag, argv in (
          ("tle", ("passes", "ISS", "--at", AT, *HERE, "--tle", "/dev/zero")),
          ("mask", ("passes", "ISS", "--at", AT, "--tle", SATS, *HERE, "--mask", "/dev/zero")),
          ("config", ("passes", "ISS", "--at", AT, "--tle", SATS, "--config", "/dev/zero")),
      )],
    c("directory-tle", "passes", "ISS", "--at", AT, *HERE, "--tle", "{tmp}",
      says="is a directory"),
    c("binary-tle", "passes", "ISS", "--at", AT, *HERE, "--tle", "{binary}",
      says="not a text file"),
    c("empty-tle", "passes", "ISS", "--at", AT, *HERE, "--tle", "{empty}",
      says="the file holds no element sets"),
    c("bom-config-accepted", "passes", "ISS", "--at", AT, "--tle", SATS, "--config", "{bom}",
      outcome="ok", says="Passes of ISS (ZARYA) over BOM"),
    # -- 13: far dates
    c("at-year-1", "passes", "ISS", "--tle", SATS, *HERE, "--at", "0001-01-01",
      says="outside 1900-2100"),
    c("at-1900", "passes", "ISS", "--tle", SATS, *HERE, "--at", "1900-01-01",
      says="days before the elements' epoch (2026-08-22"),
    c("at-2040", "next", "ISS", "--tle", SATS, *HERE, "--at", "2040-01-01",
      says="days after the elements' epoch"),
    c("at-9999-passes", "passes", "ISS", "--tle", SATS, *HERE, "--at", "9999-12-31T23:59Z",
      says="outside 1900-2100"),
    c("at-9999-next", "next", "ISS", "--tle", SATS, *HERE, "--at", "9999-12-31T23:59Z",
      says="outside 1900-2100"),
    c("at-1900-batch", "batch", SATS, *HERE, "--at", "1900-01-01",
      says="days from every element set's epoch"),
    c("at-1900-plan", "plan", "ISS", "--tle", SATS, *HERE, "--at", "1900-01-01",
      says="before the elements' epoch"),
    c("moon-past-de421", "passes", "Moon", *HERE, "--at", "2060-01-01",
      says="outside the ephemeris span"),
    c("at-empty", "passes", "ISS", "--tle", SATS, *HERE, "--at", "", says="--at is empty"),
    # -- OMM numbers and nesting, at parse time, naming file and record
    c("omm-inf", "passes", "AO-7", "--at", AT, *HERE, "--tle", "{omm_inf}",
      says="record 1 ('OSCAR 7 (AO-7)'): MEAN_MOTION should be a finite number"),
    c("omm-1e300", "passes", "AO-7", "--at", AT, *HERE, "--tle", "{omm_big}",
      says="MEAN_MOTION must be above 0 and at most 20"),
    c("omm-epoch-9999", "passes", "AO-7", "--at", AT, *HERE, "--tle", "{omm_far}",
      says="EPOCH year 9999"),
    c("nested-json-tle", "passes", "ISS", "--at", AT, *HERE, "--tle", "{nested}",
      says="nested too deeply"),
    c("nested-json-batch", "batch", "{nested}", "--at", AT, *HERE, says="nested too deeply"),
    c("nested-json-tle-show", "tle", "show", "ISS", "--tle", "{nested}",
      says="nested too deeply"),
    # -- numbers and names
    c("raw-non-ascii", "rotator", "--port", EMU_PORT, "raw", "é", says="not ASCII"),
    c("baud-huge", "rotator", "--port", EMU_PORT, "--baud", "12345678901234567890",
      "position", says="--baud 12345678901234567890 is invalid"),
    c("baud-2**32", "rotator", "--port", EMU_PORT, "--baud", "4294967296", "position",
      says="--baud 4294967296 is invalid"),
    c("upload-baud-0", "upload", "ISS", "--tle", SATS, *HERE, "--at", AT, "--baud", "0",
      says="--baud 0 is invalid"),
    c("upload-dry-run-baud-neg", "upload", "ISS", "--tle", SATS, *HERE, "--at", AT,
      "--dry-run", "--baud", "-1", says="--baud -1 is invalid"),
    c("track-baud-0", "track", "ISS", "--tle", SATS, *HERE, "--at", AT, "--baud", "0",
      says="--baud 0 is invalid"),
    *[c(f"min-max-el-{v}", "batch", SATS, *HERE, "--at", AT, "--min-max-el", v,
        says=f"--min-max-el {v} is invalid") for v in ("100", "-10", "nan", "inf")],
    *[c(f"settle-{v}", "schedule", SATS, *HERE, "--at", AT, "--settle", v,
        says="--settle") for v in ("nan", "inf", "1e12")],
    c("priority-unknown", "schedule", SATS, *HERE, "--at", AT, "--priority", "NOSUCHSAT=5",
      says="no satellite named 'nosuchsat'"),
    *[c(f"duration-{v}", "emulate", "--tcp", "0", "--duration", v, says="--duration")
      for v in ("-1", "nan", "0")],
    c("norad-1", "passes", "1", "--tle", SATS, *HERE, "--at", AT,
      says="no satellite with NORAD id 1"),
    c("socket-port-99999", "rotator", "--port", "socket://127.0.0.1:99999", "position",
      says="port 99999 is not a TCP port"),
    c("socket-no-port", "rotator", "--port", "socket://127.0.0.1", "position",
      says="names no port"),
    c("next-no-pass", "next", "ISS", "--tle", SATS, *HERE, "--at", AT, "--days", "0.05",
      "--min-el", "80", outcome="no-pass", says="no pass above 80° in the next 0.05 days"),
    # -- downloads, output files, logs
    *[c(f"tle-update-timeout-{v}", "tle", "--cache-dir", "{tmp}/cache", "update", "amateur",
        "--base-url", "http://127.0.0.1:9/", "--timeout", v, says="--timeout")
      for v in ("-1", "nan", "inf")],
    c("tle-update-base-url-garbage", "tle", "--cache-dir", "{tmp}/cache", "update",
      "amateur", "--base-url", "garbage"),
    c("tle-update-file-url", "tle", "--cache-dir", "{tmp}/cache", "update",
      "file:///etc/passwd"),
    c("steptable-missing-folder", "plan", "ISS", "--tle", SATS, *HERE, "--at", AT,
      "--steptable", "{tmp}/no/such/dir/p.steps"),
    c("steptable-directory", "plan", "ISS", "--tle", SATS, *HERE, "--at", AT,
      "--steptable", "{tmp}"),
    c("emulate-link-missing-folder", "emulate", "--pty", "--link", "{tmp}/no/such/dir/l",
      "--duration", "0.1"),
    c("emulate-link-directory", "emulate", "--pty", "--link", "{tmp}", "--duration", "0.1"),
    c("track-log-missing-folder", "track", "ISS", "--tle", SATS, *HERE, "--at", AT,
      "--log", "{tmp}/no/such/dir/t.log", "--speed", "1000"),
    c("track-log-directory", "track", "ISS", "--tle", SATS, *HERE, "--at", AT, "--log",
      "{tmp}", "--speed", "1000"),
]


pytestmark = pytest.mark.usefixtures("isolated_home")


def _files(tmp: Path) -> dict[str, str]:
    """The bad files the table refers to as {name}."""
    record = json.loads((DATA / "tle" / "amateur5.json").read_text())[0]
    out = {"tmp": str(tmp)}
    for name, change in (("omm_inf", {"MEAN_MOTION": "inf"}),
                         ("omm_big", {"MEAN_MOTION": "1e300"}),
                         ("omm_far", {"EPOCH": "9999-12-31T00:00:00"})):
        p = tmp / f"{name}.json"
        p.write_text(json.dumps([{**record, **change}]))
        out[name] = str(p)
    (tmp / "nested.json").write_text("[" * 100_000)
    (tmp / "nested.toml").write_text("a = " + "[" * 100_000)
    (tmp / "empty.tle").write_text("")
    (tmp / "binary.tle").write_bytes(bytes(range(256)) * 4)
    (tmp / "bom.toml").write_bytes(b'\xef\xbb\xbf[station]\nname = "BOM"\nlat_deg = 52.0\n'
                                   b"lon_deg = 4.4\nalt_m = 10\n")
    os.mkfifo(tmp / "fifo")
    out.update(nested_toml=str(tmp / "nested.toml"), nested=str(tmp / "nested.json"),
               empty=str(tmp / "empty.tle"),
               binary=str(tmp / "binary.tle"), bom=str(tmp / "bom.toml"),
               fifo=str(tmp / "fifo"))
    return out


def _run_in_process(argv: list[str], capsys) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as e:  # argparse
        code = e.code if isinstance(e.code, int) else 2
    out, err = capsys.readouterr()
    return code, out, err


def _limit_memory() -> None:  # pragma: no cover - runs in the child
    one_gib = 1 << 30
    resource.setrlimit(resource.RLIMIT_AS, (2 * one_gib, 2 * one_gib))


def _run_subprocess(argv: list[str], memory_limit: bool) -> tuple[int, str, str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    try:
        done = subprocess.run([sys.executable, "-m", "tracker", *argv], env=env,
                              capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL,
                              preexec_fn=_limit_memory if memory_limit else None)
    except subprocess.TimeoutExpired:
        pytest.fail(f"tracker {' '.join(argv)} did not end within 120 s (blocked?)")
    return done.returncode, done.stdout, done.stderr


@pytest.mark.parametrize("case", CASES, ids=lambda case: case.id)
def test_bad_input_gives_one_line_and_exit_2(case: Case, tmp_path, capsys):
    files = _files(tmp_path)
    argv = [a.format(**files) for a in case.argv]
    if case.subprocess:
        code, out, err = _run_subprocess(argv, case.memory_limit)
    else:
        code, out, err = _run_in_process(argv, capsys)
    assert "Traceback" not in err, err
    lines = err.splitlines()
    if case.outcome == ERROR:
        assert code == 2, (code, err)
        assert len(lines) == 1 and lines[0].startswith("tracker: error: "), err
        assert case.says in lines[0], lines[0]
    elif case.outcome == "ok":
        assert code == 0, err
        assert case.says in out
    else:  # "no-pass": an answer, not an error
        assert code == 1 and not err, err
        assert out.count("\n") == 1 and case.says in out, out
