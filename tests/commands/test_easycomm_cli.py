"""``tracker track`` and ``tracker rotator`` with ``--protocol easycomm2`` on ``emu://``: a
whole pass on virtual time, and the manual commands."""

from __future__ import annotations

import json
from datetime import datetime, timezone

from _virtual import newest_bench

from tracker.cli import main

AT = "2026-08-23T02:00:00Z"


def _config(tmp_path, monkeypatch) -> None:
    path = tmp_path / "empty.toml"
    path.write_text("")
    monkeypatch.setenv("TRACKER_CONFIG", str(path))


def test_track_a_pass_on_emu_easycomm2(tmp_path, capsys, monkeypatch):

    _config(tmp_path, monkeypatch)
    log = tmp_path / "track.jsonl"
    url = "emu://easycomm2"
    rc = main(["track", "ISS (ZARYA)", "--protocol", "easycomm2", "--port", url, "--at", AT,
               "--speed", "max", "--plain", "--log", str(log)])
    out = capsys.readouterr().out
    assert rc == 0 and "pass 1:" in out, out
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    assert any(r.get("state") == "pass_done" for r in recs)
    bench = newest_bench(url)
    try:
        wire = bench.bytes_written()
        gotos = [r for r in recs if r["kind"] == "command" and r["cmd"] == "goto"]
        assert sum(line.startswith(b"AZ") and b"EL" in line and line != b"AZ EL "
                   for line in wire.split(b"\n")) == len(gotos) >= 5
        assert wire.endswith(b"SA SE \n")          # all-stop is the last thing written
    finally:
        bench.close()


def test_rotator_goto_and_position_on_emu_easycomm2(tmp_path, capsys, monkeypatch):
    """A bench on a manual clock: the command runs on the bench's time, so the slew to the
    goto target is one clock jump instead of a real wait."""
    from tracker.clock import ManualClock
    from tracker.emulator.virtual import Bench, make_controller

    _config(tmp_path, monkeypatch)
    clock = ManualClock(datetime(2026, 8, 23, 2, tzinfo=timezone.utc))
    with Bench(make_controller("easycomm2", clock, az_deg=10.0, el_deg=5.0)) as bench:
        def rotator(*action: str) -> list[str]:
            assert main(["rotator", "--port", bench.url, "--protocol", "easycomm2",
                         *action]) == 0
            return capsys.readouterr().out.split()

        assert rotator("position") == ["10", "5"]
        rotator("goto", "90", "10")
        assert b"AZ90.0 EL10.0\n" in bench.bytes_written()
        clock.advance(60.0)
        assert rotator("position") == ["90", "10"]
