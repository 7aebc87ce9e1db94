"""``tracker upload`` and ``tracker plan --steptable`` from the command line."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from _gs232_helpers import wait_until
from test_steptable_fixtures import DATA

from tracker.cli import main
from tracker.clock import SystemClock
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.steptable import read_plan_file

TLE = str(DATA / "steptable_iss.tle")
WHERE = ["--tle", TLE, "--lat", "52", "--lon", "4.5"]
AT = ["--at", "2026-08-23T02:00:00Z"]


def test_dry_run_prints_header_and_exact_lines(capsys):
    assert main(["upload", "ISS", *WHERE, *AT, "--dry-run", "--interval", "5"]) == 0
    out = capsys.readouterr().out
    assert "# target: ISS (ZARYA)" in out and "# element_epoch: 2026-08-22" in out
    assert "# interval_s: 5 (steps every 5 s)" in out
    w = [line for line in out.splitlines() if line.startswith("W")]
    assert len(w) == 1 and w[0].startswith("W005 ")
    assert out.rstrip().endswith("\nT")


def test_plan_steptable_writes_a_file_upload_reads(tmp_path, capsys):
    f = tmp_path / "iss.steps"
    assert main(["plan", "ISS", *WHERE, *AT, "--steptable", str(f)]) == 0
    assert "step table written to" in capsys.readouterr().err
    plan = read_plan_file(f)
    assert plan.header["target"] == "ISS (ZARYA)" and plan.tables[0].kind == "W"
    assert main(["upload", "--from", str(f), "--dry-run"]) == 0
    assert capsys.readouterr().out == f.read_text()


@pytest.mark.parametrize(("header", "says"), [
    ("# t_utc: soon", "the header says t_utc soon"),
    ("# t_utc: 9999-12-31T00:00:00Z", "the header says t_utc 9999"),
    ("# interval_s: nan", "the header says interval_s nan"),
])
def test_a_header_that_contradicts_its_tables_is_refused(tmp_path, capsys, header, says):
    f = tmp_path / "iss.steps"
    assert main(["plan", "ISS", *WHERE, *AT, "--steptable", str(f)]) == 0
    key = header.split(":")[0]
    lines = [header if line.startswith(key + ":") else line
             for line in f.read_text().splitlines()]
    assert header in lines
    f.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert main(["upload", "--from", str(f), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1, err


def _tiny_plan(path: Path, start: str = "2026-08-23T02:00:00") -> None:
    path.write_text(
        "# profile: gs232b\n# rotator: G-5500\n# target: test\n"
        f"# table 1/1 points=3 upload_utc={start}.500Z arrive_utc={start}.700Z "
        f"t_utc={start[:-1]}2.000Z\n"
        "W001 010 005 011 006 012 007\nT\n")


def test_from_file_refused_when_t_has_passed(tmp_path, capsys):
    f = tmp_path / "old.steps"
    _tiny_plan(f)
    rc = main(["upload", "--from", str(f), "--port", "socket://127.0.0.1:9",
               "--at", "2026-08-23T03:00:00Z"])
    err = capsys.readouterr().err
    assert rc == 2 and "T time passed" in err and "--now" in err
    assert "Traceback" not in err


def test_from_file_sent_to_a_real_socket(tmp_path, capsys):
    f = tmp_path / "tiny.steps"
    _tiny_plan(f)
    ctrl = Gs232Controller("gs232b", clock=SystemClock(), az_deg=10, el_deg=5)
    with serve_tcp(ctrl) as server:
        t0 = time.monotonic()
        rc = main(["upload", "--from", str(f), "--port", server.url,
                   "--at", "2026-08-23T02:00:00Z"])
        elapsed = time.monotonic() - t0
        wait_until(lambda: bool(ctrl.log) and ctrl.log[-1][1] == b"S", 3)
    out = capsys.readouterr().out
    assert rc == 0, out
    lines = [line for _, line, _ in ctrl.log]
    assert b"W001 010 005 011 006 012 007" in lines and b"T" in lines and lines[-1] == b"S"
    assert 2.5 < elapsed < 10            # waited for T at +2 s, ran to the end at +4 s
    assert "T timing" in out and "wire time at 9600 baud" in out


def test_bad_inputs_exit_2_with_one_line(tmp_path, capsys):
    assert main(["upload", "ISS", *WHERE, *AT, "--dry-run", "--interval", "0"]) == 2
    assert "1-999" in capsys.readouterr().err
    assert main(["upload", "ISS", *WHERE, *AT, "--protocol", "rotorez", "--dry-run"]) == 2
    assert "no timed step tables" in capsys.readouterr().err
    bad = tmp_path / "bad.steps"
    bad.write_text("# table 1/1 points=2 upload_utc=x arrive_utc=y t_utc=z\nW001 1 2\nT\n")
    assert main(["upload", "--from", str(bad), "--dry-run"]) in (0, 2)
    assert main(["upload", "--from", str(bad), "--port", "socket://127.0.0.1:9"]) == 2
    assert "bad.steps:1" in capsys.readouterr().err


def test_simulation_without_port_says_so(capsys):
    rc = main(["upload", "ISS", *WHERE, *AT, "--interval", "10", "--speed", "100"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "SIMULATION" in out and "Nothing real moves" in out
    assert "all-stop sent" in out and "T sent" in out


def test_from_file_with_now_resumes_at_the_point_due(tmp_path, capsys):
    # T passed 2.5 s ago: --now sends only the points still to come, starting with the one
    # due when the upload lands, and T when the next one is due.
    f = tmp_path / "late.steps"
    start = "2026-08-23T02:00:00"
    f.write_text(
        "# profile: gs232b\n# rotator: G-5500\n# target: test\n"
        f"# table 1/1 points=7 upload_utc={start}.500Z arrive_utc={start}.700Z "
        f"t_utc={start[:-1]}2.000Z\n"
        "W001 010 005 011 006 012 007 013 008 014 009 015 010 016 011\nT\n")
    ctrl = Gs232Controller("gs232b", clock=SystemClock(), az_deg=13, el_deg=8)
    with serve_tcp(ctrl) as server:
        rc = main(["upload", "--from", str(f), "--port", server.url, "--now",
                   "--at", "2026-08-23T02:00:04.500Z"])
        wait_until(lambda: bool(ctrl.log) and ctrl.log[-1][1] == b"S", 3)
    out = capsys.readouterr().out
    assert rc == 0, out
    lines = [line for _, line, _ in ctrl.log]
    # At 02:00:04.5 point 4 (013 008) is due (T at :02 -> point 2, :03 -> 3, :04 -> 4).
    assert b"W001 013 008 014 009 015 010 016 011" in lines, lines
    assert b"T" in lines and lines[-1] == b"S"
    assert "resyncs: 0" in out


def test_config_rotator_is_used_and_named_in_the_plan_file(tmp_path, capsys):
    # A [rotator.NAME] section works for upload as for plan and track, and a plan file made
    # for it is read back with the same rotator; an unknown one is refused, not replaced.
    cfg = tmp_path / "config.toml"
    cfg.write_text('[rotator.roof]\npreset = "G-5500"\nmains_hz = 50\nel_max_deg = 170\n')
    f = tmp_path / "roof.steps"
    assert main(["plan", "ISS", *WHERE, *AT, "--config", str(cfg), "--rotator", "roof",
                 "--steptable", str(f)]) == 0
    capsys.readouterr()
    assert read_plan_file(f).header["rotator"] == "roof"
    assert main(["upload", "ISS", *WHERE, *AT, "--config", str(cfg), "--rotator", "roof",
                 "--dry-run"]) == 0
    assert "# rotator: roof" in capsys.readouterr().out
    rc = main(["upload", "--from", str(f), "--port", "socket://127.0.0.1:9", "--now",
               "--at", "2026-08-23T02:00:00Z"])
    err = capsys.readouterr().err
    assert rc == 2 and "rotator 'roof'" in err and "--rotator" in err, err
    rc = main(["upload", "ISS", *WHERE, *AT, "--config", str(cfg), "--rotator", "roof",
               "--mains-hz", "60", "--dry-run"])
    assert rc == 2 and "mains_hz = 60 in that section" in capsys.readouterr().err


def test_from_file_is_checked_against_this_station_and_rotator(tmp_path, capsys):
    # The tiny plan points at 5-7 deg elevation: refused, before anything is sent, where the
    # horizon mask is 10 deg (the plan file does not carry the mask it was made for).
    f = tmp_path / "tiny.steps"
    _tiny_plan(f)
    mask = tmp_path / "horizon.txt"
    mask.write_text("0 10\n")
    rc = main(["upload", "--from", str(f), "--port", "socket://127.0.0.1:9", "--now",
               "--mask", str(mask), "--at", "2026-08-23T02:00:00Z"])
    err = capsys.readouterr().err
    assert rc == 2 and "point 1 (010 005) is below the horizon mask" in err, err
    assert err.count("\n") == 1 and "Traceback" not in err



def test_upload_plans_inside_what_the_controller_takes(capsys, monkeypatch):
    """A controller that takes elevation up to 90 only (its driver reports el_max_deg 90):
    the near-overhead pass at 05:20, a keyhole over the top (el to 180) on a G-5500, is
    planned inside 0-90 and runs to the end on virtual time (emu:// bench, ManualClock),
    instead of being refused at the upload."""
    from _virtual import manual_clock, virtual_rig

    from tracker import protocols
    from tracker.mount import preset

    rig = virtual_rig(Gs232Controller("gs232b", preset("G-5500"),
                                      clock=manual_clock(1787461200.0)))  # 05:00 UTC
    real_open = protocols.open_driver

    def el_up_to_90(url, protocol="gs232b", **kw):
        return real_open(url, protocol, **{**kw, "el_max_deg": 90.0})

    monkeypatch.setattr(protocols, "open_driver", el_up_to_90)
    try:
        rc = main(["upload", "ISS", *WHERE, "--port", rig.url])
        wire = rig.written()
    finally:
        rig.close()
    out, err = capsys.readouterr()
    assert rc == 0, out + err
    assert "planning inside the controller's limits: az 0-450, el 0-90" in out, out
    assert "keyhole" not in out and "T sent" in out and "all-stop sent" in out, out
    tables = [line for line in wire.split(b"\r") if line.startswith(b"W")]
    el = [int(v) for line in tables for v in line[1:].split()[2::2]]
    assert tables and max(el) > 60 and max(el) <= 90, max(el)
    assert wire.endswith(b"S\r")


def test_a_large_predicted_error_is_explained(tmp_path, capsys, monkeypatch):
    """K3NG stepping every 5 s through an 83 deg pass: the warning says why the error is
    large (the interval), and what helps."""
    (tmp_path / "empty.toml").write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(tmp_path / "empty.toml"))
    assert main(["upload", "ISS", "--protocol", "k3ng", "--rotator", "generic-k3ng",
                 "--interval", "4", "--dry-run", "--at", "2026-08-24T04:20:00Z"]) == 0
    err = capsys.readouterr().err
    assert "the interval is too long for this pass" in err and "--interval" in err


def test_upload_reports_the_measured_pointing_error(tmp_path, capsys):
    """Each progress line carries the measured error (read-back against where the ISS is at
    that moment) and the run ends with the pass's measured maximum, close to the prediction;
    a plan file carries no sky track, so its error is said to be unknown, not invented.
    Virtual time: emu:// benches on ManualClocks."""
    import re

    from _virtual import manual_clock, virtual_rig

    from tracker.mount import preset

    rig = virtual_rig(Gs232Controller("gs232b", preset("G-5500"),
                                      clock=manual_clock(1787461200.0)))  # 05:00 UTC
    try:
        rc = main(["upload", "ISS", *WHERE, "--port", rig.url])
    finally:
        rig.close()
    out, err = capsys.readouterr()
    assert rc == 0, out + err
    steps = [line for line in out.splitlines() if "  step " in line]
    assert steps and all(re.search(r"el \d+, pointing error \d+\.\d deg$", s) for s in steps)
    predicted = float(re.search(r"predicted error max ([\d.]+) deg", out).group(1))
    last = out.splitlines()[-1]
    m = re.fullmatch(r"measured: max pointing error ([\d.]+) deg over (\d+) read-backs", last)
    assert m and int(m.group(2)) > 100, last
    assert float(m.group(1)) <= predicted + 0.5

    f = tmp_path / "tiny.steps"
    _tiny_plan(f)
    rig = virtual_rig(Gs232Controller("gs232b", preset("G-5500"), az_deg=10, el_deg=5,
                                      clock=manual_clock(1787450400.0)))  # 02:00 UTC
    try:
        rc = main(["upload", "--from", str(f), "--port", rig.url])
    finally:
        rig.close()
    out = capsys.readouterr().out
    assert rc == 0, out
    assert out.splitlines()[-1] == ("measured pointing error: unknown (the plan file "
                                    "carries no sky track of the target)")


def test_the_simulation_replays_stale_elements_at_their_epoch(capsys, monkeypatch):
    """Elements far older than today (the test TLE's epoch is 2026-08-22): the simulation
    replays a pass just after their epoch, says so once, and does not also warn about their
    age; as `tracker track`'s demo. Its clock and emulator run on virtual time here."""
    from datetime import datetime, timezone

    from tracker import clock as clocks
    from tracker import emulator
    from tracker.clock import ManualClock
    from tracker.emulator.virtual import Bench

    if datetime.now(timezone.utc) < datetime(2026, 9, 20, tzinfo=timezone.utc):
        pytest.skip("the test elements are not stale yet")
    made: list[ManualClock] = []

    def virtual_clock(start, speed):
        made.append(ManualClock(start))
        return made[-1]

    monkeypatch.setattr(clocks, "SimClock", virtual_clock)
    monkeypatch.setattr(emulator, "serve_pty", Bench)
    rc = main(["upload", "ISS", *WHERE, "--interval", "10"])
    out, err = capsys.readouterr()
    assert rc == 0, out + err
    assert "days old (epoch 2026-08-22" in out and "replays a pass just after" in out, out
    assert "old" not in err, err
    assert made and made[0].now() < datetime(2026, 8, 25, tzinfo=timezone.utc), made[0].now()
    assert "all-stop sent" in out and out.splitlines()[-1].startswith("measured: max")


def test_a_stop_while_planning_after_connecting_sends_all_stop(capsys, monkeypatch):
    """Upload connects before it plans; a Ctrl-C (or SIGTERM/SIGHUP, which take its path)
    during the planning still leaves all-stop as the last thing on the wire."""
    from _virtual import manual_clock, virtual_rig

    from tracker.commands import upload
    from tracker.mount import preset

    rig = virtual_rig(Gs232Controller("gs232b", preset("G-5500"),
                                      clock=manual_clock(1787461200.0)))

    def interrupted(*_a, **_kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(upload, "build_program", interrupted)
    try:
        rc = main(["upload", "ISS", *WHERE, "--port", rig.url])
        wire = rig.written()
    finally:
        rig.close()
    assert rc == 130
    assert wire.endswith(b"S\r"), wire          # nothing was sent before: S alone
