"""`tracker passes`, `tracker next` and `tracker config` from the command line.

Most tests call ``tracker.cli.main`` in-process (fast); a few run the installed console script
as a real process to prove the README command works and errors never show a traceback.
The element cache and config dir point at empty temp dirs, so the bundled snapshot is used.
"""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys

import pytest
from _paths import DATA

from tracker.cli import main
from tracker.commands.passes import format_duration
from tracker.export import CSV_FIELDS, JSON_SCHEMA_ID, PASS_FIELDS

SATS = str(DATA / "passes_sats.tle")
AT = "2026-08-23T00:00:00Z"
HERE = ["--lat", "52.0", "--lon", "4.4", "--alt", "10"]


pytestmark = pytest.mark.usefixtures("isolated_home")


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_table_for_iss(capsys):
    code, out, err = run(capsys, "passes", "ISS (ZARYA)", "--at", AT, *HERE, "--tle", SATS)
    assert code == 0
    lines = out.splitlines()
    assert lines[0].startswith("Passes of ISS (ZARYA) over 52.0000N 4.4000E (52.0000, 4.4000)")
    assert lines[1].split()[:3] == ["AOS", "(UTC)", "Duration"]  # local time is UTC here
    rows = [ln for ln in lines[2:] if ln.startswith("Sun 08-23")]
    assert 4 <= len(rows) <= 8
    # first pass of the day: AOS 02:07:45 UTC from the south-south-west (see test_passes)
    assert "02:07:4" in rows[0] and "SSW" in rows[0]
    assert "old" not in err or "elements for ISS" in err  # age warning only, no noise


def test_csv_columns_and_values(capsys):
    code, out, _ = run(capsys, "passes", "25544", "--at", AT, *HERE, "--tle", SATS,
                       "--format", "csv", "--hours", "12")
    assert code == 0
    reader = csv.DictReader(io.StringIO(out))
    assert tuple(reader.fieldnames) == CSV_FIELDS
    rows = list(reader)
    assert rows and all(r["target"] == "ISS (ZARYA)" for r in rows)
    assert all(r["station"] == "52.0000N 4.4000E" and r["plan_mode"] == "" for r in rows)
    for r in rows:
        assert r["aos"] < r["tca"] < r["los"] and r["aos"].endswith("Z")
        assert 0 < float(r["max_el_deg"]) <= 90 and r["sunlit"] in ("true", "false")
        assert r["aos_known"] == "true" and r["always_up"] == "false"


def test_json_and_min_el(capsys):
    code, out, _ = run(capsys, "passes", "ISS", "--at", AT, *HERE, "--tle", SATS,
                       "--format", "json", "--days", "2", "--min-el", "30")
    assert code == 0
    doc = json.loads(out)
    assert doc["schema"] == JSON_SCHEMA_ID and doc["errors"] == []
    assert doc["meta"]["stations"][0]["min_el_deg"] == 30.0
    assert (doc["meta"]["start"], doc["meta"]["end"]) == ("2026-08-23T00:00:00Z",
                                                          "2026-08-25T00:00:00Z")
    assert doc["meta"]["targets"] == ["ISS (ZARYA)"]
    assert doc["passes"] and all(p["max_el_deg"] > 30 for p in doc["passes"])
    assert tuple(doc["passes"][0]) == PASS_FIELDS


def test_group_lists_several_targets(capsys):
    code, out, _ = run(capsys, "passes", "--group", "passes_sats", "--tle", SATS,
                       "--at", AT, *HERE, "--hours", "3")
    assert code == 0
    assert out.splitlines()[1].startswith("Target")
    assert "ES'HAIL 2" in out and "always up" in out
    assert "YAMAL" not in out  # never rises here
    # No row is marked "*" (ES'HAIL 2 says "always up"), so no "*" footnote either.
    assert " *" not in out and "already in progress" not in out


def test_in_progress_marker(capsys):
    code, out, _ = run(capsys, "passes", "ISS", "--at", "2026-08-23T03:50:00Z", *HERE,
                       "--tle", SATS, "--hours", "1")
    assert code == 0
    assert "03:43:1" in out and " *" in out and "already in progress" in out


def test_next_one_line(capsys):
    code, out, _ = run(capsys, "next", "ISS", "--at", AT, *HERE, "--tle", SATS)
    assert code == 0 and out.count("\n") == 1
    assert out.startswith("ISS (ZARYA): next AOS 2026-08-23 02:07:4")
    assert " in 2h07m, max el 14°" in out
    code, out, _ = run(capsys, "next", "ISS", "--at", "2026-08-23T03:50:00Z", *HERE,
                       "--tle", SATS)
    assert code == 0 and "up now" in out and "LOS in 4m0" in out
    code, out, _ = run(capsys, "next", "YAMAL 300K", "--at", AT, *HERE, "--tle", SATS,
                       "--days", "2")
    assert code == 1 and "no pass above 0° in the next 2 days" in out
    code, out, _ = run(capsys, "next", "ES'HAIL 2", "--at", AT, *HERE, "--tle", SATS)
    assert code == 0 and "always up" in out


@pytest.mark.parametrize(("argv", "message"), [
    (["passes", "ISX", "--tle", SATS], "did you mean"),
    (["passes", "--tle", SATS], "name a target"),
    (["passes", "ISS", "--tle", SATS, "--at", "yesterday"], "cannot read the time 'yesterday'"),
    (["passes", "ISS", "--tle", SATS, "--hours", "0"], "the window must be more than 0"),
    (["passes", "ISS", "--tle", SATS, "--lat", "123"], "lat_deg = 123.0 is out of range"),
    (["passes", "ISS", "--tle", SATS, "--station", "roof"], "no station 'roof'"),
    (["passes", "ISS", "--tle", SATS, "--group", "nope"], "no group 'nope'"),
    (["next", "DECAYSAT", "--tle", str(DATA / "passes_decayed.tle"), "--at",
      "2026-08-25T00:00Z"], "DECAYSAT (NORAD 25544): the elements cannot be propagated"),
])
def test_errors_are_one_line_exit_2(capsys, argv, message):
    code, _, err = run(capsys, *argv)
    assert code == 2
    last = err.strip().splitlines()[-1]
    assert last.startswith("tracker: error: ") and message in last
    assert "Traceback" not in err


def test_bad_tle_file_names_file_and_line(capsys, tmp_path):
    bad = tmp_path / "bad.tle"
    lines = (DATA / "passes_sats.tle").read_text().splitlines()[:3]
    lines[2] = lines[2][:-1] + str((int(lines[2][-1]) + 1) % 10)  # break the checksum
    bad.write_text("\n".join(lines) + "\n")
    code, _, err = run(capsys, "passes", "ISS", "--tle", str(bad), "--at", AT)
    assert code == 2 and "Traceback" not in err
    # Nothing usable in the file: the one line is the fault itself, naming file:line.
    (line,) = err.strip().splitlines()
    assert line.startswith(f"tracker: error: no usable element set: {bad}:3: ")
    assert "checksum expected" in line


def test_broken_set_among_good_ones_is_skipped_with_a_warning(capsys, tmp_path):
    mixed = tmp_path / "mixed.tle"
    good = (DATA / "passes_sats.tle").read_text()
    lines = good.splitlines()[:3]
    lines[0] = "BROKEN"
    lines[2] = lines[2][:-1] + str((int(lines[2][-1]) + 1) % 10)
    mixed.write_text(good + "\n".join(lines) + "\n")
    code, out, err = run(capsys, "next", "ISS", "--tle", str(mixed), "--at", AT, *HERE)
    assert code == 0 and out.startswith("ISS (ZARYA): next AOS")
    warnings = [ln for ln in err.splitlines() if "skipped a broken element set" in ln]
    assert len(warnings) == 1 and f"{mixed}:" in warnings[0] and "'BROKEN'" in warnings[0]


def test_bad_config_exit_2(capsys, tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[station]\nlat_deg = 52\nlon_deg = 400\n")
    code, _, err = run(capsys, "passes", "ISS", "--tle", SATS, "--config", str(cfg))
    assert code == 2
    # Only the error: no element-age warning or other note before it.
    (line,) = err.strip().splitlines()
    assert line == (f"tracker: error: {cfg}: [station] lon_deg = 400 is invalid; allowed: a "
                    "number from -180 to 180")


def test_config_station_used_and_flags_override(capsys, tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[station]\nname = \"pole\"\nlat_deg = 89\nlon_deg = 0\n")
    code, out, _ = run(capsys, "passes", "ISS", "--tle", SATS, "--config", str(cfg),
                       "--at", AT)
    assert code == 0 and "no passes" in out and "pole" in out
    code, out, _ = run(capsys, "passes", "ISS", "--tle", SATS, "--config", str(cfg),
                       "--at", AT, "--lat", "52")
    assert code == 0 and "no passes" not in out


def test_config_init_show_path(capsys, tmp_path):
    cfg = tmp_path / "config.toml"
    code, out, _ = run(capsys, "config", "init", "--config", str(cfg))
    assert code == 0 and cfg.exists()
    cfg.write_text(cfg.read_text().replace("lat_deg = 52.0", "lat_deg = 51.25"))
    code, _, err = run(capsys, "config", "init", "--config", str(cfg))
    assert code == 2 and "already exists" in err
    assert "lat_deg = 51.25" in cfg.read_text()  # nothing saved is lost
    code, out, _ = run(capsys, "config", "show", "--config", str(cfg), "--min-el", "7")
    assert code == 0
    assert "lat_deg = 51.25" in out and "min_el_deg = 7.0" in out and "[rotator.home]" in out
    code, out, _ = run(capsys, "config", "path", "--config", str(cfg))
    assert out.strip() == str(cfg)
    code, out, _ = run(capsys, "config", "show")
    assert code == 0 and "no config file" in out and "lat_deg = 52.0" in out


def test_config_init_takes_the_location_and_the_note_stays_until_then(capsys, tmp_path):
    cfg = str(tmp_path / "config.toml")
    passes = ["passes", "ISS", "--config", cfg, "--at", AT, "--hours", "2", "--tle", SATS]
    code, out, _ = run(capsys, "config", "init", "--config", cfg)
    assert code == 0 and "placeholder station 52.0 N 4.4 E" in out
    code, _, err = run(capsys, *passes)
    assert code == 0 and "is still the placeholder" in err       # the note stays
    code, _, err = run(capsys, *passes, "--locator", "JO32")
    assert code == 0 and "placeholder" not in err                 # flags replace it
    code, out, _ = run(capsys, "config", "init", "--config", cfg, "--force", "--locator",
                       "JO22xb")
    assert code == 0 and 'locator = "JO22xb"' in (tmp_path / "config.toml").read_text()
    code, out, err = run(capsys, *passes)
    assert code == 0 and "placeholder" not in err and "no station" not in err
    assert "over home (52.0625, 5.9583)" in out
    code, out, _ = run(capsys, "config", "init", "--config", cfg, "--force", "--lat", "-33.9",
                       "--lon", "18.4", "--alt", "40")
    code, out, _ = run(capsys, "config", "show", "--config", cfg)
    assert "lat_deg = -33.9" in out and "lon_deg = 18.4" in out and "alt_m = 40.0" in out


@pytest.mark.parametrize(("argv", "message"), [
    (["config", "init", "--locator", "JO2"], "must have 2, 4, 6 or 8 characters"),
    (["config", "init", "--lat", "52"], "give both --lat and --lon"),
    (["config", "init", "--lat", "52", "--lon", "4", "--locator", "JO22"], "not both"),
    (["passes", "ISS", "--locator", "XX22"], "--locator: Maidenhead locator 'XX22'"),
    (["passes", "ISS", "--locator", "JO22", "--lat", "52"], "not both"),
])
def test_bad_locations_are_one_line(capsys, tmp_path, argv, message):
    config = ["--config", str(tmp_path / "c.toml")] if argv[0] == "config" else []
    code, _, err = run(capsys, *argv, *config)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "c.toml").exists()


def test_a_locator_flag_names_the_station(capsys):
    code, out, _ = run(capsys, "passes", "ISS", "--locator", "JO22xb", "--at", AT, "--tle",
                       SATS, "--hours", "2")
    assert code == 0 and out.startswith("Passes of ISS (ZARYA) over JO22xb (52.0625, 5.9583)")


def test_local_time_column_when_not_utc(capsys, monkeypatch):
    import time

    monkeypatch.setenv("TZ", "Europe/Amsterdam")
    time.tzset()
    try:
        code, out, _ = run(capsys, "passes", "ISS", "--at", AT, *HERE, "--tle", SATS,
                           "--hours", "3")
    finally:
        monkeypatch.setenv("TZ", "UTC")
        time.tzset()
    assert code == 0
    header, first = out.splitlines()[1:3]
    assert header.split()[:4] == ["AOS", "(CEST)", "AOS", "UTC"]
    assert first.startswith("Sun 08-23 04:07:4") and "02:07:4" in first


def test_format_duration():
    assert [format_duration(s) for s in (0, 59.4, 61, 3599, 3600, 5000, 90000)] == [
        "0s", "59s", "1m01s", "59m59s", "1h00m", "1h23m", "1d01h"]


def _proc(*argv, tmp_path):
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"),
               XDG_CONFIG_HOME=str(tmp_path / "config"), TZ="UTC")
    env.pop("TRACKER_CONFIG", None)
    return subprocess.run([sys.executable, "-m", "tracker", *argv], capture_output=True,
                          text=True, env=env, timeout=120)


def test_readme_command_as_a_process(tmp_path):
    """`tracker passes "ISS (ZARYA)"` on a fresh machine: bundled elements, default station,
    real time now; old elements are flagged loudly but passes are still listed."""
    r = _proc("passes", "ISS (ZARYA)", tmp_path=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "Passes of ISS (ZARYA)" in r.stdout
    assert "no station configured" in r.stderr and "tracker config init" in r.stderr
    if "WARNING" in r.stderr:  # elements older than 30 days
        assert "tracker tle update" in r.stderr


def test_error_as_a_process_has_no_traceback(tmp_path):
    r = _proc("passes", "NO SUCH SATELLITE 42", "--tle", SATS, tmp_path=tmp_path)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("tracker: error: ")
