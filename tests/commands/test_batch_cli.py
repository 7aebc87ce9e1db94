"""``tracker batch`` / ``tracker schedule`` end to end through the CLI (in process and as a
subprocess), including bad input: one line, exit 2, nothing already saved is lost."""

from __future__ import annotations

import csv
import io
import itertools
import json
import subprocess
import sys

import icalendar
import pytest
from _paths import DATA, REPO

from tracker.cli import main

AT = "2026-08-22T13:45Z"
STATIONS = "name,lat_deg,lon_deg,alt_m,min_el_deg\nDelft,52.0,4.37,10,0\nQuito,-0.2,-78.5,2850,5\n"


pytestmark = pytest.mark.usefixtures("isolated_home")


@pytest.fixture
def stations(tmp_path) -> str:
    path = tmp_path / "stations.csv"
    path.write_text(STATIONS)
    return str(path)


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_batch_csv_two_stations(capsys, stations):
    code, out, err = run(capsys, "batch", "amateur", "--stations", stations, "--days", "1",
                         "--at", AT, "--format", "csv", "--min-max-el", "10")
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert {r["station"] for r in rows} == {"Delft", "Quito"}
    assert all(float(r["max_el_deg"]) >= 10 for r in rows)
    assert "passes of 96 satellites over 2 station(s)" in err


def test_batch_json_with_plans_and_visible_filter(capsys, stations, tmp_path):
    out_file = tmp_path / "p.json"
    code, out, err = run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", AT,
                         "--format", "json", "--rotator", "G-5500", "--min-max-el", "30",
                         "--out", str(out_file))
    assert code == 0, err
    assert out == ""
    doc = json.loads(out_file.read_text())
    assert doc["schema"] == "rotator-tracker/passes/2"
    assert doc["meta"]["rotator"] == "G-5500"
    modes = {p["plan_mode"] for p in doc["passes"] if p["plan_mode"]}
    assert modes and modes <= {"normal", "overlap", "flip", "keyhole", "unwind", "ahead"}
    assert all(p["max_el_deg"] >= 30 for p in doc["passes"])
    code, out, err = run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at",
                         AT, "--format", "json", "--visible")
    vis = json.loads(out)["passes"]
    assert all(p["visible"] and p["sunlit"] for p in vis)
    assert 0 < len(vis) < len(json.loads(
        run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", AT,
            "--format", "json")[1])["passes"])


def test_batch_ics_parses(capsys, tmp_path):
    out_file = tmp_path / "p.ics"
    code, _, err = run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", AT,
                       "--format", "ics", "--out", str(out_file), "--min-max-el", "20")
    assert code == 0, err
    cal = icalendar.Calendar.from_ical(out_file.read_bytes())
    events = [c for c in cal.walk() if c.name == "VEVENT"]
    assert len(events) > 10
    assert all(" max " in str(e["SUMMARY"]) for e in events)


def test_batch_tle_file_and_timeline_plot(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    src = DATA / "batch_active_sample.txt"
    png = tmp_path / "timeline.png"
    code, out, err = run(capsys, "batch", str(src), "--lat", "40", "--lon", "-105.3",
                         "--at", "2026-03-19T04:51Z", "--days", "0.5", "--plot", str(png))
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "satellite" in out.splitlines()[0]


def test_schedule_picks_by_priority(capsys, tmp_path):
    code, out, err = run(capsys, "schedule", "amateur", "--lat", "52", "--lon", "4.37",
                         "--at", AT, "--days", "1", "--min-max-el", "20", "--format", "json",
                         "--rotator", "G-5500", "--priority", "FUNCUBE-1 (AO-73)=9", "--all")
    assert code == 0, err
    doc = json.loads(out)
    passes = doc["passes"]
    chosen = [p for p in passes if p["chosen"]]
    assert 0 < len(chosen) < len(passes)
    assert doc["meta"]["chosen"] == len(chosen)
    ao73 = [p for p in passes if p["target"] == "FUNCUBE-1 (AO-73)"]
    assert ao73 and all(p["chosen"] for p in ao73)  # the top priority is never dropped
    chosen.sort(key=lambda p: p["aos_s"])
    assert all(a["los_s"] < b["aos_s"] for a, b in itertools.pairwise(chosen))
    assert all(p["conflicts_with"] for p in passes if not p["chosen"])


def test_schedule_needs_one_station(capsys, stations):
    code, _, err = run(capsys, "schedule", "amateur", "--stations", stations, "--at", AT)
    assert code == 2 and "one station" in err


@pytest.mark.parametrize("argv,match", [
    (["batch", "nosuchgroup", "--lat", "1", "--lon", "2"], "no group 'nosuchgroup'"),
    (["batch", "missing.txt", "--lat", "1", "--lon", "2"], "missing.txt: no such file"),
    (["batch", "amateur", "--stations", "nope.csv"], "cannot read stations file nope.csv"),
    (["batch", "amateur", "--lat", "1", "--lon", "2", "--days", "0"], "--days 0"),
    (["batch", "amateur", "--lat", "1", "--lon", "2", "--rotator", "nope"], "unknown rotator"),
    (["batch", "amateur", "--lat", "1", "--lon", "2", "--at", "yesterday"], "cannot read the"),
    (["schedule", "amateur", "--lat", "1", "--lon", "2", "--priority", "ISS"], "NAME=N"),
])
def test_bad_input_is_one_line_exit_2(capsys, argv, match):
    code, _out, err = run(capsys, *argv, *(["--at", AT] if "--at" not in argv else []))
    assert code == 2
    assert match in err and err.count("\n") == 1 and "Traceback" not in err


def test_failed_run_keeps_the_existing_output_file(capsys, tmp_path):
    out_file = tmp_path / "passes.csv"
    out_file.write_text("precious\n")
    code, _, _err = run(capsys, "batch", "amateur", "--lat", "1", "--lon", "2", "--at", AT,
                       "--rotator", "nope", "--out", str(out_file))
    assert code == 2
    assert out_file.read_text() == "precious\n"


def test_broken_stations_file_as_a_subprocess(tmp_path):
    bad = tmp_path / "st.csv"
    bad.write_text("Delft,52,4.37,10\nOops,91,0,0\n")
    proc = subprocess.run([sys.executable, "-m", "tracker", "batch", "amateur", "--stations",
                           str(bad), "--at", AT], capture_output=True, text=True, timeout=60,
                          env={"PATH": "/usr/bin:/bin", "XDG_CONFIG_HOME": str(tmp_path),
                               "XDG_CACHE_HOME": str(tmp_path), "HOME": str(tmp_path)})
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"tracker: error: {bad}:2: ")
    assert "Traceback" not in proc.stderr


def test_sky_plots_of_planned_passes(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    folder = tmp_path / "sky"
    folder.mkdir()
    code, _, err = run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", AT,
                       "--days", "0.1", "--min-max-el", "40", "--rotator", "G-5500",
                       "--sky-plots", str(folder), "--format", "csv")
    assert code == 0, err
    pngs = sorted(folder.glob("*.png"))
    assert pngs and all(p.read_bytes()[:4] == b"\x89PNG" for p in pngs)
    code, _, err = run(capsys, "batch", "amateur", "--lat", "52", "--lon", "4.37", "--at", AT,
                       "--sky-plots", str(folder))
    assert code == 2 and "--sky-plots needs --rotator" in err


def test_dask_missing_is_one_clear_line(tmp_path):
    """The base install has no dask: ``--dask`` says which extra to install (exit 2)."""
    # None in sys.modules makes ``import dask...`` fail exactly as when it is not installed.
    code = ("import sys; sys.modules['dask'] = sys.modules['distributed'] = None; "
            "from tracker.cli import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", code, "batch", "amateur", "--lat", "52",
                           "--lon", "4.37", "--at", AT, "--days", "0.1", "--dask"],
                          capture_output=True, text=True, timeout=120,
                          env={"PATH": "/usr/bin:/bin", "XDG_CONFIG_HOME": str(tmp_path),
                               "XDG_CACHE_HOME": str(tmp_path), "HOME": str(tmp_path)})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == ("tracker: error: --dask needs dask.distributed: pip install "
                           "'rotator-tracker[dask]'\n")


def test_json_meta_and_schedule_fields_are_documented(capsys):
    doc_text = (REPO / "docs" / "pass-schema.md").read_text()
    code, out, err = run(capsys, "schedule", "amateur", "--lat", "52", "--lon", "4.37",
                         "--at", AT, "--days", "0.3", "--min-max-el", "20", "--format", "json",
                         "--rotator", "G-5500", "--all")
    assert code == 0, err
    doc = json.loads(out)
    assert set(doc) == {"schema", "meta", "passes", "errors"}
    for key in doc["meta"]:
        assert f"`{key}`" in doc_text, f"meta.{key} is not documented"
    assert doc["passes"]
    for p in doc["passes"]:
        for key in p:
            assert f"`{key}`" in doc_text, f"passes[].{key} is not documented"
