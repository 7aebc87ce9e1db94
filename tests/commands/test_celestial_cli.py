"""The CLI accepts celestial and schedule targets wherever it accepts satellites."""

from __future__ import annotations

import json
from datetime import datetime, timezone

import pytest
from _paths import DATA, REPO

from tracker.celestial import resolve
from tracker.cli import main
from tracker.passes import find_passes
from tracker.station import Station

pytest.importorskip("skyfield_data")
pytest.importorskip("tracker.commands.passes")

AT = "2026-08-22T00:00:00Z"
SWEEP = DATA / "schedule_sweep.csv"


@pytest.fixture
def config(tmp_path) -> str:
    path = tmp_path / "tracker.toml"
    path.write_text('[station]\nname = "dwingeloo"\nlat_deg = 52.81\nlon_deg = 6.40\n'
                    "alt_m = 20.0\nmin_el_deg = 0.0\n")
    return str(path)


def test_passes_moon_json_matches_find_passes(config, capsys):
    rc = main(["passes", "moon", "--at", AT, "--days", "2", "--format", "json",
               "--config", config])
    out = capsys.readouterr().out
    assert rc == 0
    doc = json.loads(out)
    rows = doc["passes"]
    assert len(rows) == 2 and all(r["kind"] == "moon" for r in rows)
    station = Station("dwingeloo", 52.81, 6.40, 20.0)
    mine = find_passes(resolve("moon"), station, datetime(2026, 8, 22, tzinfo=timezone.utc),
                         datetime(2026, 8, 24, tzinfo=timezone.utc))
    for row, p in zip(rows, mine, strict=True):
        aos = datetime.fromisoformat(row["aos"].replace("Z", "+00:00")).timestamp()
        los = datetime.fromisoformat(row["los"].replace("Z", "+00:00")).timestamp()
        assert abs(aos - p.aos.timestamp()) <= 0.5 and abs(los - p.los.timestamp()) <= 0.5
        assert abs(row["aos_s"] - p.aos.timestamp()) < 1.0
        assert row["max_el_deg"] == pytest.approx(p.max_el_deg, abs=0.02)


@pytest.mark.parametrize("name", ["Sun", "JUPITER", "Cas A", "radec:83.63,22.01",
                                  str(SWEEP), f"schedule:{SWEEP}"])
def test_passes_accepts_celestial_names(config, capsys, name):
    rc = main(["passes", name, "--at", AT, "--format", "csv", "--config", config])
    out = capsys.readouterr().out.strip().splitlines()
    assert rc == 0
    assert out[0].startswith("target,kind,")
    assert len(out) >= 2  # every one of these is up at some time that day


def test_bad_radec_is_one_line_exit_2(config, capsys):
    rc = main(["passes", "radec:25:00:00,+10:00", "--at", AT, "--config", config])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("tracker: error: bad fixed position") and err.count("\n") == 1


def test_bad_schedule_file_is_file_line_exit_2(config, capsys, tmp_path):
    bad = tmp_path / "sweep.csv"
    bad.write_text("2026-08-22T18:00:00Z,100,10\n2026-08-22T18:05:00Z,400,10\n")
    rc = main(["passes", str(bad), "--at", AT, "--config", config])
    err = capsys.readouterr().err
    assert rc == 2
    assert f"{bad}:2: azimuth 400 is out of range" in err and "Traceback" not in err


def test_next_moon(config, capsys):
    if not REPO.joinpath("tracker/commands/next.py").exists():
        pytest.skip("no next command")
    rc = main(["next", "moon", "--at", AT, "--config", config])
    out = capsys.readouterr().out
    assert rc == 0 and "Moon" in out


def test_eme_example_runs_for_a_fixed_night(capsys):
    import runpy

    script = REPO / "examples" / "eme_moon_night.py"
    module = runpy.run_path(str(script), run_name="eme_example")
    rc = module["main"](["--lat", "52.81", "--lon", "6.40", "--at", "2026-08-22T12:00Z",
                         "--rows", "2"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "rise     2026-08-22 16:28:" in out and "set      2026-08-22 22:25:" in out
    assert "fits one 1900-pair step table" in out
    assert "-0.0" not in out
