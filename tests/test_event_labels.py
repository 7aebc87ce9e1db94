"""Satellites have AOS/LOS; the Sun, Moon and radio sources rise and set (CLI wording)."""

import pytest

from tracker.cli import main
from tracker.event_labels import event_labels

AT = ["--at", "2026-08-23T00:00Z", "--lat", "52", "--lon", "4.4"]


def test_labels_by_kind():
    assert event_labels("satellite") == ("AOS", "TCA", "LOS")
    assert event_labels("moon") == ("rise", "transit", "set")
    assert event_labels("radio") == ("rise", "transit", "set")


@pytest.mark.parametrize(("target", "word", "absent"), [
    ("moon", "Rise", "AOS"),
    ("Cas A", "Rise", "AOS"),
    ("ISS (ZARYA)", "AOS", "Rise"),
])
def test_passes_table_uses_the_targets_words(capsys, target, word, absent):
    assert main(["passes", target, "--days", "1", *AT]) == 0
    header = next(line for line in capsys.readouterr().out.splitlines() if "Duration" in line)
    assert f"{word} " in header and absent not in header


def test_next_says_rise_for_the_moon_and_aos_for_a_satellite(capsys):
    assert main(["next", "moon", *AT]) == 0
    assert "next rise" in capsys.readouterr().out
    assert main(["next", "ISS (ZARYA)", *AT]) == 0
    assert "next AOS" in capsys.readouterr().out
