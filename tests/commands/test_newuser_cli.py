"""The small things a new user met (issue: README, first hardware, clear output): each one
refused or shown clearly."""

from __future__ import annotations

import importlib.util
import socket

import pytest
from _gs232_helpers import WAIT_S

from tracker.cli import main

AT = "2026-08-23T02:05:00Z"
HERE = ["--lat", "52.0", "--lon", "4.4"]


@pytest.fixture(autouse=True)
def isolated(isolated_home, monkeypatch):
    monkeypatch.chdir(isolated_home)   # files the commands write land here


@pytest.fixture
def no_matplotlib(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "matplotlib" else real(name, *a))


@pytest.mark.parametrize("argv", [
    ["plan", "ISS", *HERE, "--plot", "iss.png"],
    ["batch", "amateur", *HERE, "--days", "0.1", "--plot", "t.png"],
    ["schedule", "amateur", *HERE, "--days", "0.1", "--plot", "t.png"],
    ["batch", "amateur", *HERE, "--days", "0.1", "--rotator", "G-5500", "--sky-plots", "."],
])
def test_plot_needs_matplotlib_before_anything_is_computed(capsys, no_matplotlib, argv):
    assert main([*argv, "--at", AT]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.strip().splitlines() == [
        "tracker: error: plotting needs matplotlib: pip install 'rotator-tracker[plot]'"]


@pytest.mark.parametrize("argv", [
    ["track", "ISS (ZARYA)", "--protocol", "gs232x"],
    ["track", "ISS (ZARYA)", "--port", "emu://gs232b", "--at", AT, "--protocol", "gs232x"],
    ["upload", "ISS (ZARYA)", "--dry-run", "--protocol", "gs232x"],
    ["rotator", "--protocol", "gs232x", "--port", "emu://gs232b", "position"],
])
def test_an_unknown_protocol_is_refused_before_anything_is_printed(capsys, argv):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert "protocol 'gs232x'" in err


def test_goto_with_elevation_on_an_azimuth_only_protocol_is_refused(capsys):
    url = "emu://rotorez?rotator=G-400"
    assert main(["rotator", "--protocol", "rotorez", "--rotator", "G-400", "--port", url,
                 "goto", "90", "30"]) == 2
    err = capsys.readouterr().err
    assert "this rotator moves in azimuth only; give AZ alone" in err
    assert len(err.strip().splitlines()) == 1


def test_a_station_given_by_flags_has_a_readable_name_in_the_calendar(capsys):
    assert main(["batch", "stations", *HERE, "--days", "0.5", "--format", "ics",
                 "--at", AT]) == 0
    out = capsys.readouterr().out
    assert "command-line" not in out
    assert "LOCATION:52.0000N 4.4000E" in out.replace("\r\n ", "")


def test_a_controller_silent_for_the_whole_pass_does_not_exit_0(capsys):
    port = "emu://gs232b?fault=silent=3000@100"
    code = main(["track", "ISS (ZARYA)", "--port", port, "--at", AT, "--plain", *HERE])
    assert code == 2
    assert "no reply" in capsys.readouterr().err


def test_sak232_emulator_answers_the_gs23_subset(emulate):
    box = emulate("--protocol", "sak232", "--gs23", "--tcp", "0", "--az", "120")
    host, port = box.url.removeprefix("socket://").rsplit(":", 1)
    reply = b""
    with socket.create_connection((host, int(port)), timeout=WAIT_S) as s:
        s.sendall(b"C\r")
        while b"\n" not in reply:
            chunk = s.recv(64)
            if not chunk:
                break
            reply += chunk
    assert reply.startswith(b"+0120"), reply
    box.stop()


def test_gs23_is_for_sak232_only(capsys):
    assert main(["emulate", "--protocol", "gs232b", "--gs23", "--tcp", "0"]) == 2
    assert "--gs23 is a SAK-232 option" in capsys.readouterr().err
