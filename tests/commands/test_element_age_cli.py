"""Every command that uses elements flags stale ones (and ones from the future of --at) the
same way, through the one ``_common.warn_element_age``."""

from __future__ import annotations

import pytest

from tracker.cli import main

HERE = ["--lat", "52.0", "--lon", "4.4"]
STALE_AT = "2026-10-05T08:20:00Z"    # the bundled ISS set is 43.8 days old; a pass at 08:24
FUTURE_AT = "2025-08-22T00:00:00Z"   # a year before the bundled epochs
STALE = "WARNING: elements for ISS (ZARYA) are 44 days old"


@pytest.fixture(autouse=True)
def isolated(isolated_home, monkeypatch):
    monkeypatch.chdir(isolated_home)   # files the commands write land here


@pytest.mark.parametrize("argv", [
    ["passes", "ISS (ZARYA)"],
    ["next", "ISS (ZARYA)"],
    ["plan", "ISS (ZARYA)"],
    ["plan", "ISS (ZARYA)", "--steptable", "iss.steps"],
    ["upload", "ISS (ZARYA)", "--dry-run"],
    ["track", "ISS (ZARYA)", "--port", "emu://gs232b", "--plain"],
    ["tle", "show", "ISS (ZARYA)"],
], ids=lambda a: " ".join(a[:2] + a[3:4]))
def test_one_target_commands_flag_stale_elements(capsys, argv):
    station = [] if argv[0] == "tle" else HERE
    assert main([*argv, *station, "--at", STALE_AT]) == 0
    err = capsys.readouterr().err
    assert f"tracker: {STALE}" in err
    assert err.count("elements for ISS (ZARYA)") == 1


@pytest.mark.parametrize("command", ["batch", "schedule"])
def test_catalogue_commands_flag_stale_elements_in_one_line(capsys, command):
    assert main([command, "stations", *HERE, "--days", "0.1", "--at", STALE_AT]) == 0
    err = capsys.readouterr().err
    assert "element sets are more than 7 days from the time asked for" in err


@pytest.mark.parametrize("command", ["passes", "plan"])
def test_elements_from_the_future_of_at_are_flagged(capsys, command):
    argv = [command, "ISS (ZARYA)", *HERE, "--at", FUTURE_AT]
    if command == "plan":
        argv += ["--hours", "24"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "WARNING: elements for ISS (ZARYA) are from 366 days after the time asked" in err
