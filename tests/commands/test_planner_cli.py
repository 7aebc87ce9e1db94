"""``tracker plan``: report, JSON, sky plot, and clear errors (exit 2, no traceback)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tracker.cli import main

AT = ["--at", "2026-08-23T00:00Z", "--lat", "48.15", "--lon", "11.57"]


pytestmark = pytest.mark.usefixtures("isolated_home")


def test_plan_report_lists_mode_reason_and_every_candidate(capsys):
    assert main(["plan", "ISS", "--rotator", "G-5400B", "--mains-hz", "50", *AT]) == 0
    out = capsys.readouterr().out
    assert "on G-5400B@50Hz" in out
    assert "mode: " in out and "why:  " in out
    assert "candidate" in out and out.count("\n*") == 1  # the chosen one is marked
    assert "pre-position: start" in out and "park after LOS" in out
    assert "predicted pointing error: max" in out and "motor starts" in out
    # the count is said to be of the plan's command steps, not of what live tracking does
    assert "motor starts count every 1 deg command step of this path" in out


def test_plan_json_and_pass_number(capsys):
    assert main(["plan", "AO-7", "--pass", "2", "--format", "json", *AT]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["mode"] in ("normal", "overlap", "flip", "keyhole", "unwind", "ahead")
    assert data["candidates"][0]["mode"] == data["mode"]
    assert data["aos"] >= "2026-08-23"
    assert data["preposition_moves"] or data["preposition_az_deg"] == 0


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_plan_plot(tmp_path, suffix, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / f"sky{suffix}"
    assert main(["plan", "AO-7", "--plot", str(out), *AT]) == 0
    assert out.stat().st_size > 1000
    head = out.read_bytes()[:8]
    assert head.startswith(b"\x89PNG") if suffix == ".png" else b"<" in head


@pytest.mark.parametrize("argv, message", [
    (["plan", "AO-7", "--pass", "0"], "numbered from 1"),
    (["plan", "AO-7", "--pass", "500", "--hours", "2"], "only"),
    (["plan", "AO-7", "--rotator", "G-9999"], "unknown rotator"),
    (["plan", "AO-7", "--plot", "sky.txt"], ".png or .svg"),
    (["plan", "NO SUCH SATELLITE"], "NO SUCH SATELLITE"),
])
def test_plan_errors_are_one_line_exit_2(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main([*argv, *AT]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: ") and message in err
    assert "Traceback" not in err


def test_plan_runs_as_a_program(tmp_path):
    env_cmd = [sys.executable, "-m", "tracker", "plan", "AO-7", *AT]
    res = subprocess.run(env_cmd, capture_output=True, text=True, timeout=120,
                         env={"XDG_CONFIG_HOME": str(tmp_path), "XDG_CACHE_HOME": str(tmp_path),
                              "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert res.returncode == 0, res.stderr
    assert "mode: " in res.stdout


ROOF = """
[station]
lat_deg = 48.15
lon_deg = 11.57

[rotator.roof]
preset = "G-5500"
mains_hz = 50
az_span_deg = 360
el_max_deg = 170
park_az_deg = 180
"""


def test_plan_uses_a_rotator_from_the_config_file(tmp_path, capsys):
    cfg = tmp_path / "tracker.toml"
    cfg.write_text(ROOF)
    assert main(["plan", "ISS", "--pass", "5", "--rotator", "roof", "--config", str(cfg),
                 "--format", "json", "--at", "2026-08-23T00:00Z"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["rotator"] == "roof"
    assert data["park_moves"][-1]["az_deg"] == 180  # the section's park position
    for c in data["candidates"]:  # flips are clamped at the section's el max, not 180
        if c["mode"] == "flip":
            assert "clamped at 170" in c["note"]


@pytest.mark.parametrize("override, field", [
    ("stop_bearing_deg = 360", "stop_bearing_deg = 360"),
    ("az_rate_deg_s = 0", "az_rate_deg_s = 0"),
    ("el_rate_deg_s = -1", "el_rate_deg_s = -1"),
    ("az_speed_rates_deg_s = [1, \"x\"]", "az_speed_rates_deg_s[1]"),
])
def test_bad_rotator_section_is_one_line_exit_2(override, field, tmp_path, capsys):
    cfg = tmp_path / "tracker.toml"
    cfg.write_text(ROOF + override + "\n")
    assert main(["plan", "ISS", "--rotator", "roof", "--config", str(cfg), *AT]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: ") and err.count("\n") == 1
    assert "[rotator.roof]" in err and field in err


def test_plot_to_an_unwritable_path_is_one_line_exit_2(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    assert main(["plan", "AO-7", "--plot", str(tmp_path / "no" / "sky.png"), *AT]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tracker: error: --plot") and "does not exist" in err
    assert "Traceback" not in err


def test_mains_hz_flag_is_refused_for_a_config_rotator(tmp_path, capsys):
    cfg = tmp_path / "tracker.toml"
    cfg.write_text(ROOF)
    assert main(["plan", "ISS", "--rotator", "roof", "--mains-hz", "60", "--config", str(cfg),
                 "--at", "2026-08-23T00:00Z"]) == 2
    assert "mains_hz = 60 in that section" in capsys.readouterr().err
