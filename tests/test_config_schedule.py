"""The config's [schedule] section (station mode): both forms of the priorities, defaults,
one-line errors naming ``file: [schedule] key``, and the template's commented example."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from test_config import write

from tracker.config import ScheduleSettings, load_config, parse_config, template_text
from tracker.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def test_table_form_and_every_key(tmp_path):
    p = write(tmp_path, """
[schedule]
targets = { "ISS (ZARYA)" = 3, "NOAA 20" = 2, "25544" = 0 }
groups = { weather = 1 }
min_max_el_deg = 15
mode = "table"
park = false
refresh_h = 6
horizon_h = 36
settle_s = 90
sources = ["weather", "stations"]
""")
    s = load_config(p).schedule
    assert s == ScheduleSettings(
        targets={"ISS (ZARYA)": 3, "NOAA 20": 2, "25544": 0}, groups={"weather": 1},
        min_max_el_deg=15.0, mode="table", park=False, refresh_h=6.0, horizon_h=36.0,
        settle_s=90.0, sources=("weather", "stations"))
    assert s.element_sources == ("weather", "stations")


def test_list_form_defaults_and_sources():
    s = parse_config({"schedule": {"targets": ["ISS (ZARYA)=3", "SO-50", " NOAA 19 = 2 "]}},
                     Path("c.toml")).schedule
    assert dict(s.targets) == {"ISS (ZARYA)": 3, "SO-50": 1, "NOAA 19": 2}
    assert (s.min_max_el_deg, s.mode, s.park, s.refresh_h, s.horizon_h, s.settle_s) == (
        10.0, "auto", True, 12.0, 24.0, 60.0)
    assert s.element_sources == ("amateur", "weather", "stations", "visual")  # store default
    groups = parse_config({"schedule": {"groups": {"weather": 1, "amateur": 2}}},
                          Path("c.toml")).schedule
    assert groups.element_sources == ("weather", "amateur")


def test_no_schedule_section_is_none(tmp_path):
    assert load_config(write(tmp_path, "[tracking]\nlead_s = 1\n")).schedule is None


def test_show_output_reads_back(tmp_path):
    p = write(tmp_path, '[schedule]\ntargets = ["SO-50"]\ngroups = { weather = 2 }\n'
                        'sources = ["weather"]\n')
    config = load_config(p)
    again = parse_config(tomllib.loads(config.to_toml()), p)
    assert again.schedule == config.schedule


def test_template_example_parses_when_uncommented():
    text = template_text()
    assert "# [schedule]" in text and "# targets = {" in text
    on = "\n".join(line[2:] if line.startswith(("# [schedule]", "# targets =", "# groups =",
                                                 "# mode =", "# refresh_h ="))
                   else line for line in text.splitlines())
    s = parse_config(tomllib.loads(on), Path("t.toml")).schedule
    assert dict(s.targets) == {"ISS (ZARYA)": 3, "NOAA 20": 2}
    assert dict(s.groups) == {"weather": 1} and s.mode == "auto" and s.refresh_h == 12.0


@pytest.mark.parametrize(("body", "message"), [
    ('targets = { "ISS" = -1 }',
     '[schedule] targets.ISS = -1 is invalid; allowed: a whole number from 0 (never) to 1000'),
    ('targets = { "ISS" = 1.5 }', "[schedule] targets.ISS = 1.5 is invalid"),
    ('targets = ["ISS=x2"]\ngroups = { weather = true }',
     "[schedule] groups.weather = true is invalid"),
    ('targets = ["=3"]', '[schedule] targets item "=3" is invalid; allowed: "NAME=N" or "NAME"'),
    ('targets = "ISS"', "[schedule] targets = \"ISS\" is invalid; allowed: a table"),
    ('targets = { "ISS" = 0 }', "[schedule] names nothing to track"),
    ("min_max_el_deg = 95\ngroups = { weather = 1 }",
     "[schedule] min_max_el_deg = 95 is invalid; allowed: a number from 0 to 90"),
    ("refresh_h = 1\ngroups = { weather = 1 }",
     "[schedule] refresh_h = 1 is invalid; allowed: a number from 2 to 168"),
    ('mode = "fast"\ngroups = { weather = 1 }',
     '[schedule] mode = "fast" is invalid; allowed: stream, table, auto'),
    ("park = 1\ngroups = { weather = 1 }", "[schedule] park = 1 is invalid; allowed: true or"),
    ("sources = []\ngroups = { weather = 1 }", "[schedule] sources = [] is invalid"),
    ("horizon = 24\ngroups = { weather = 1 }",
     "[schedule] unknown key 'horizon'; allowed keys: targets, groups, min_max_el_deg"),
])
def test_errors_name_file_section_and_key(tmp_path, body, message):
    p = write(tmp_path, f"[schedule]\n{body}\n")
    with pytest.raises(ConfigError) as info:
        load_config(p)
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{p}: ")
    assert message in text


def test_schedule_is_a_known_section(tmp_path):
    with pytest.raises(ConfigError, match=r"allowed sections: .*\[schedule\]"):
        load_config(write(tmp_path, "[schedules]\n"))
