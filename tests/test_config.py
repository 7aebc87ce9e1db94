"""The TOML config: stations, rotators (preset + overrides), tracking defaults, errors that name
``file: [section] key = value`` and the allowed range, and the no-config default."""

from __future__ import annotations

import re
import sys

import pytest

from tracker.config import (
    DEFAULT_STATION,
    Config,
    load_config,
    parse_config,
    template_text,
    write_template,
)
from tracker.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def write(tmp_path, text: str):
    p = tmp_path / "config.toml"
    p.write_text(text)
    return p


def test_template_is_valid_and_commented(tmp_path):
    p = write_template(tmp_path / "config.toml")
    text = p.read_text()
    assert text == template_text() and text.count("#") > 20
    config = load_config(p)
    assert config.station.name == "home" and config.station.lat_deg == 52.0
    assert not config.station_is_default and config.station_is_placeholder
    assert config.rotator().name == "home"
    assert config.rotator().az_span_deg == 450  # from the G-5500 preset


def test_init_makes_only_its_own_config_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    own = write_template(tmp_path / "xdg" / "tracker" / "config.toml")
    assert own.read_text() == template_text()          # the tool's folder is made on first use
    with pytest.raises(ConfigError, match="does not exist"):
        write_template(tmp_path / "typo" / "config.toml")
    assert not (tmp_path / "typo").exists()     # a user's path grows no folders


def test_init_never_overwrites_without_force(tmp_path):
    p = write(tmp_path, "[station]\nlat_deg = 1.0\nlon_deg = 2.0\n")
    with pytest.raises(ConfigError, match=r"already exists.*force=True"):
        write_template(p)
    assert p.read_text() == "[station]\nlat_deg = 1.0\nlon_deg = 2.0\n"
    write_template(p, force=True)
    assert p.read_text() == template_text()


def test_named_stations_and_rotators(tmp_path):
    (tmp_path / "hz.txt").write_text("0 5\n180 15\n")
    p = write(tmp_path, """
[station]
name = "home"
lat_deg = 51.5
lon_deg = -0.1
alt_m = 30
min_el_deg = 2
mask = "hz.txt"

[station.portable]
lat_deg = 48.0
lon_deg = 11.0

[tracking]
rotator = "roof"
station = "portable"
park_after_pass = false
deadband_deg = 2.5

[rotator.roof]
preset = "G-5500"
mains_hz = 50
stop_bearing_deg = 180
az_span_deg = 360
el_max_deg = 90

[rotator.azonly]
az_span_deg = 360
el_max_deg = "none"
az_rate_deg_s = 4.0
""")
    config = load_config(p)
    assert config.station.name == "portable"  # [tracking] station chooses the default
    home = config.station_named("home")
    assert home.mask is not None and home.horizon_at(90.0) == pytest.approx(10.0)
    assert home.alt_m == 30.0 and home.min_el_deg == 2.0
    roof = config.rotator()
    assert roof.stop_bearing_deg == 180 and roof.el_max_deg == 90
    assert roof.az_rate_deg_s == pytest.approx(360 / 58 * 50 / 60)  # 50 Hz slows the motor
    assert not config.rotator("azonly").has_elevation
    assert config.rotator("G-5500").name == "G-5500"  # presets stay available
    assert config.tracking == {"rotator": "roof", "station": "portable",
                               "park_after_pass": False, "deadband_deg": 2.5}
    with pytest.raises(ConfigError, match=r"no station 'mars'.*known stations: home, portable"):
        config.station_named("mars")
    # show output is TOML that reads back to the same values
    again = parse_config(tomllib.loads(config.to_toml()), p)
    assert again.station == config.station
    assert again.rotator("roof") == roof
    assert again.station_named("home").mask == home.mask


@pytest.mark.parametrize(("text", "message"), [
    ("[station]\nlat_deg = 95\nlon_deg = 4\n",
     "[station] lat_deg = 95 is invalid; allowed: a number from -90 to 90"),
    ("[station]\nlat_deg = \"north\"\nlon_deg = 4\n",
     "[station] lat_deg = \"north\" is invalid; allowed: a number from -90 to 90"),
    ("[station]\nlat_deg = 50\n", "[station] lon_deg is missing"),
    ("[station]\nlat_deg = 50\nlon_deg = 4\nelevation = 3\n",
     "[station] unknown key 'elevation'; allowed keys: name, lat_deg"),
    ("[station.car]\nlat_deg = 50\nlon_deg = 4\nmin_el_deg = -20\n",
     "[station.car] min_el_deg = -20 is invalid; allowed: a number from -5 to 90"),
    ("[rotator.r]\npreset = \"G-5500\"\naz_span_deg = 500\n",
     "[rotator.r] rotator 'r': az_span_deg = 500 is invalid; allowed: 360 to 450 degrees"),
    ("[rotator.r]\nspeed = 3\n", "[rotator.r] unknown key 'speed'; allowed keys: preset"),
    ("[rotator.r]\npreset = \"G-9999\"\n", "unknown rotator 'G-9999'; known presets"),
    ("[rotator.r]\nmains_hz = 55\n", "[rotator.r] mains_hz = 55 is invalid; allowed: 50 or 60"),
    ("[tracking]\ndeadband_deg = 99\n",
     "[tracking] deadband_deg = 99 is invalid; allowed: 0 to 30 degrees"),
    ("[tracking]\nrotator = \"nope\"\n", "[tracking] rotator = \"nope\" is invalid; allowed:"),
    ("[tracking]\nbaud = 9600\n", "[tracking] unknown key 'baud'"),
    ("[tracking]\npark_after_pass = 1\n",
     "[tracking] park_after_pass = 1 is invalid; allowed: true or false"),
    ("[stations]\nlat_deg = 1\n", "unknown section or key 'stations'"),
    ("[station\nlat_deg = 1\n", "invalid TOML"),
])
def test_invalid_values_name_file_section_key_and_range(tmp_path, text, message):
    p = write(tmp_path, text)
    with pytest.raises(ConfigError) as e:
        load_config(p)
    assert str(e.value).startswith(f"{p}: ")
    assert message in str(e.value)


def test_bad_mask_path_in_config(tmp_path):
    p = write(tmp_path, "[station]\nlat_deg = 1\nlon_deg = 2\nmask = \"nope.txt\"\n")
    with pytest.raises(ConfigError, match=re.escape(f"cannot read horizon mask "
                                                    f"{tmp_path / 'nope.txt'}")):
        load_config(p)


def test_no_file_gives_the_documented_default(tmp_path, monkeypatch):
    monkeypatch.delenv("TRACKER_CONFIG", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    config = load_config()
    assert config.station_is_default and config.station == DEFAULT_STATION
    assert config.path is None
    assert (config.station.lat_deg, config.station.lon_deg) == (52.0, 4.4)
    assert Config().rotator().name == "G-5500"


def test_env_var_and_explicit_path(tmp_path, monkeypatch):
    p = write(tmp_path, "[station]\nname = \"envst\"\nlat_deg = 10\nlon_deg = 20\n")
    monkeypatch.setenv("TRACKER_CONFIG", str(p))
    assert load_config().station.name == "envst"
    monkeypatch.setenv("TRACKER_CONFIG", str(tmp_path / "missing.toml"))
    with pytest.raises(ConfigError, match=r"does not exist; create it with write_template"):
        load_config()
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(tmp_path / "other.toml")


def test_tracking_mains_hz_slows_presets_but_not_own_sections(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('[tracking]\nmains_hz = 50\n[rotator.roof]\npreset = "G-5500"\n'
                 'mains_hz = 60\n')
    config = load_config(p)
    assert config.rotator("G-5500").name == "G-5500@50Hz"
    assert config.rotator("g-5500").az_rate_deg_s == pytest.approx(
        config.rotator("roof").az_rate_deg_s * 5 / 6)
    assert config.rotator("G-1000DXA").name == "G-1000DXA"   # DC motors: mains independent
    assert config.user_rotator("ROOF") is config.rotator("roof")
    assert config.user_rotator("G-5500") is None


def test_config_option_before_the_subcommand(tmp_path, capsys):
    from tracker.cli import main

    p = tmp_path / "c.toml"
    p.write_text('[station]\nname = "roof"\nlat_deg = 10.5\nlon_deg = 20.0\n')
    assert main(["--config", str(p), "config", "show"]) == 0
    out = capsys.readouterr().out
    assert str(p) in out and "lat_deg = 10.5" in out
    assert main(["--config", str(tmp_path / "none.toml"), "config", "show"]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_a_locator_instead_of_lat_lon(tmp_path):
    config = load_config(write(tmp_path, '[station]\nlocator = "JO22xb"\n'))
    assert (config.station.lat_deg, config.station.lon_deg) == pytest.approx((52.0625, 5.95833),
                                                                             abs=1e-4)
    assert not config.station_is_placeholder


@pytest.mark.parametrize(("text", "message"), [
    ('locator = "JO22"\nlat_deg = 1.0', "both locator and lat_deg/lon_deg"),
    ('locator = "ZZ22"', r"\[station\] Maidenhead locator 'ZZ22': character 1"),
    ("locator = 22", "allowed: a Maidenhead locator"),
])
def test_bad_locators_are_one_clear_line(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write(tmp_path, f"[station]\n{text}\n"))


def test_template_with_a_position(tmp_path):
    p = write_template(tmp_path / "a.toml", text=template_text(40.5, -75.25, 20.0))
    config = load_config(p)
    assert (config.station.lat_deg, config.station.lon_deg, config.station.alt_m) == (
        40.5, -75.25, 20.0)
    assert not config.station_is_placeholder
    p = write_template(tmp_path / "b.toml", text=template_text(locator="JO22"))
    assert load_config(p).station.lat_deg == 52.5 and "PLACEHOLDER" not in p.read_text()
