"""The config file: one TOML file with the station(s), rotators and tracking defaults.

Where it is: ``--config FILE``, else ``$TRACKER_CONFIG``, else ``config.toml`` in the
platformdirs user config dir (``~/.config/tracker/config.toml`` on Linux). If there is no
file, :data:`DEFAULT_STATION` is used and commands say so.

Sections::

    [station]                 name, lat_deg + lon_deg or locator (Maidenhead), alt_m,
                              min_el_deg, mask (file path)
    [station.NAME]            more stations, chosen with --station NAME / [tracking] station
    [rotator.NAME]            preset = "G-5500", mains_hz = 50, + any RotatorSpec field
    [tracking]                rotator, station, protocol, port, baudrate, park_after_pass, ...
    [schedule]                station mode: targets, groups (priorities), min_max_el_deg,
                              mode, park, refresh_h, horizon_h, settle_s, sources

Every invalid value raises :class:`~tracker.errors.ConfigError` naming
``file: [section] key = value`` and what is allowed; unknown keys are rejected by name.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tracker.errors import ConfigError, with_advice
from tracker.mount import PRESETS, RotatorSpec, preset
from tracker.station import STATION_RANGES, Station, locator_lat_lon, mask_file, parse_station

ENV_VAR = "TRACKER_CONFIG"
FILE_NAME = "config.toml"

# Used when no config file exists: a documented, obviously-placeholder location (the Dutch
# coast, near Leiden) so pass times are plausible for a European user and easy to recognise.
DEFAULT_STATION = Station(name="default-52.0N-4.4E", lat_deg=52.0, lon_deg=4.4, alt_m=0.0,
                          min_el_deg=0.0)


# [tracking] keys: name -> (type(s), description of what is allowed). Other parts of the
# program read these through Config.tracking; an unknown key is a typo and is rejected.
TRACKING_KEYS: dict[str, tuple[tuple[type, ...], str]] = {
    "rotator": ((str,), "a [rotator.NAME] section or a preset name"),
    "station": ((str,), "a [station.NAME] section name"),
    "protocol": ((str,), "a controller protocol name such as gs232a, gs232b, k3ng, rotorez"),
    "port": ((str,), "a serial port or pyserial URL, e.g. /dev/ttyUSB0 or socket://host:4533"),
    "baudrate": ((int,), "a positive integer, e.g. 9600"),
    "park_after_pass": ((bool,), "true or false"),
    "deadband_deg": ((int, float), "0 to 30 degrees"),
    "lead_s": ((int, float), "0 to 60 seconds"),
    "update_interval_s": ((int, float), "0.1 to 60 seconds"),
    "timeout_s": ((int, float), "0.1 to 60 seconds"),
    "min_el_deg": ((int, float), "-5 to 90 degrees"),
    "mains_hz": ((int,), "50 or 60"),
}
_TRACKING_RANGES = {"deadband_deg": (0.0, 30.0), "lead_s": (0.0, 60.0),
                    "update_interval_s": (0.1, 60.0), "timeout_s": (0.1, 60.0),
                    "min_el_deg": (-5.0, 90.0), "baudrate": (1, 10_000_000)}

_ROTATOR_FIELDS = {f.name: f for f in dataclasses.fields(RotatorSpec)
                   if f.name not in ("name", "extra")}


# [schedule]: what station mode tracks and how (tracker.service.plan reads it).
SCHEDULE_MODES = ("stream", "table", "auto")
MAX_PRIORITY = 1000
# number keys -> (lowest, highest) allowed
_SCHEDULE_RANGES = {"min_max_el_deg": (0.0, 90.0), "refresh_h": (2.0, 168.0),
                    "horizon_h": (1.0, 168.0), "settle_s": (0.0, 3600.0)}
SCHEDULE_KEYS = ("targets", "groups", "min_max_el_deg", "mode", "park", "refresh_h",
                 "horizon_h", "settle_s", "sources")


@dataclass(frozen=True)
class ScheduleSettings:
    """The ``[schedule]`` section: what a station run tracks, unattended.

    ``targets``: satellite name (as :meth:`tle.catalog.Catalog.find` takes it), NORAD id or
    another target name ("Sun") -> priority (> 0 tracks, higher wins an overlap; 0 never,
    also for an object of a group below). ``groups``: element group ("weather", "amateur")
    -> the priority of each object in it. Passes whose max elevation is below
    ``min_max_el_deg`` are not scheduled. ``mode``: "stream" (the live loop), "table" (step
    tables on the controller) or "auto" (tables where they are predicted to point well
    enough). ``park``: park between passes (else stay). ``refresh_h``: element refresh
    interval (at least 2 h, the download rule the element store enforces). ``horizon_h``: how
    far ahead the rolling schedule reaches. ``settle_s``: time kept free between passes.
    ``sources``: element sources to refresh (default: :attr:`element_sources`).
    """

    targets: Mapping[str, int] = field(default_factory=dict)
    groups: Mapping[str, int] = field(default_factory=dict)
    min_max_el_deg: float = 10.0
    mode: str = "auto"
    park: bool = True
    refresh_h: float = 12.0
    horizon_h: float = 24.0
    settle_s: float = 60.0
    sources: tuple[str, ...] = ()

    @property
    def element_sources(self) -> tuple[str, ...]:
        """What to download: ``sources``, else the groups named, else the store's default
        groups (they hold the usual single targets such as the ISS)."""
        if self.sources:
            return self.sources
        if self.groups:
            return tuple(self.groups)
        from tle.store import DEFAULT_GROUPS

        return tuple(DEFAULT_GROUPS)

    def toml_lines(self) -> list[str]:
        """The section as TOML lines (``tracker config show``)."""
        def table(m: Mapping[str, int]) -> str:
            return "{ " + ", ".join(f"{_key(k)} = {v}" for k, v in m.items()) + " }"

        lines = [f"targets = {table(self.targets)}", f"groups = {table(self.groups)}"]
        lines += [f"{k} = {_toml_value(getattr(self, k))}" for k in SCHEDULE_KEYS[2:]
                  if k != "sources" or self.sources]
        return lines


def default_config_path() -> Path:
    """``$TRACKER_CONFIG`` or the platformdirs user config file."""
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env).expanduser()
    from platformdirs import user_config_dir

    return Path(user_config_dir("tracker")) / FILE_NAME


@dataclass(frozen=True)
class Config:
    """The effective configuration.

    ``station`` is the default station; ``stations`` holds every named one (the default too,
    under its name). ``rotators`` holds the presets and every ``[rotator.NAME]`` section.
    ``tracking`` is the validated ``[tracking]`` table. ``path`` is the file read, or None.
    """

    station: Station = DEFAULT_STATION
    stations: dict[str, Station] = field(default_factory=dict)
    rotators: dict[str, RotatorSpec] = field(default_factory=lambda: dict(PRESETS))
    tracking: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None
    station_is_default: bool = True
    mask_paths: dict[str, str] = field(default_factory=dict)  # station name -> mask file
    schedule: ScheduleSettings | None = None  # [schedule]: station mode; None if absent

    @property
    def station_is_placeholder(self) -> bool:
        """No station configured, or the default station still at the placeholder position
        that ``tracker config init`` writes when given no location."""
        return self.station_is_default or (
            (self.station.lat_deg, self.station.lon_deg)
            == (DEFAULT_STATION.lat_deg, DEFAULT_STATION.lon_deg))

    def station_named(self, name: str | None = None) -> Station:
        """The named station (``[station.NAME]``), or the default one for None."""
        if not name:
            return self.station
        if name in self.stations:
            return self.stations[name]
        known = ", ".join(sorted(self.stations)) or "none"
        raise ConfigError(f"no station {name!r} in {self.path or 'the config'}; "
                          f"known stations: {known} (add a [station.{name}] section)")

    def rotator(self, name: str | None = None) -> RotatorSpec:
        """The named rotator, else ``[tracking] rotator``, else the G-5500 preset."""
        name = name or self.tracking.get("rotator") or "G-5500"
        user = self.user_rotator(name)
        if user is not None:
            return user
        return preset(name, int(self.tracking.get("mains_hz", 60)))

    def user_rotator(self, name: str) -> RotatorSpec | None:
        """The ``[rotator.NAME]`` section called ``name`` (any case), or None for a preset."""
        for key, spec in self.rotators.items():
            if key.lower() == name.lower() and PRESETS.get(key) is not spec:
                return spec
        return None

    def to_toml(self) -> str:
        """The effective config as TOML (what ``tracker config show`` prints)."""
        lines = [f"# effective config; file: {self.path or '(none: built-in defaults)'}", ""]
        masks = self.mask_paths
        lines += ["[station]", *_station_lines(self.station, masks.get(self.station.name))]
        for name, st in self.stations.items():
            if st is self.station and name == self.station.name:
                continue
            lines += ["", f"[station.{_key(name)}]", *_station_lines(st, masks.get(name))]
        if self.tracking:
            lines += ["", "[tracking]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in self.tracking.items()]
        if self.schedule is not None:
            lines += ["", "[schedule]", *self.schedule.toml_lines()]
        for name, spec in self.rotators.items():
            lines += ["", f"[rotator.{_key(name)}]"]
            for fname in _ROTATOR_FIELDS:
                value = getattr(spec, fname)
                if value is None:
                    value = "none"
                lines.append(f"{fname} = {_toml_value(value)}")
        return "\n".join(lines) + "\n"


def _key(name: str) -> str:
    bare = name.replace("-", "").replace("_", "").isalnum()
    return name if bare else _toml_value(name)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    s = str(v).replace("\\", "\\\\").replace('"', '\\"')
    return f'"{s}"'


def _station_lines(st: Station, mask_path: str | None = None) -> list[str]:
    out = [f"name = {_toml_value(st.name)}"]
    out += [f"{k} = {_toml_value(float(getattr(st, k)))}" for k in STATION_RANGES]
    if mask_path:
        out.append(f"mask = {_toml_value(mask_path)}")
    if st.mask is not None:
        src = mask_path
        pts = ", ".join(f"{a:g} {e:g}" for a, e in zip(st.mask.az_deg, st.mask.min_el_deg,
                                                          strict=True))
        out.append(f"# mask{' from ' + str(src) if src else ''}: {pts}")
    return out


def _read_toml(path: Path) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    from tle.textfile import read_text_file

    text = read_text_file(path, "config file", ConfigError,
                          hint="is this a TOML config file?")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: invalid TOML: {e}; see `tracker config init` for the "
                          f"format") from None
    except RecursionError:   # the parser nests one call per [ : a config has a few levels
        raise ConfigError(f"{path}: TOML nested too deeply to be a config file; see "
                          f"`tracker config init` for the format") from None


def _number(path: Path, section: str, key: str, value: Any, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value) or not (lo <= value <= hi):
        raise ConfigError(f"{path}: [{section}] {key} = {_toml_value(value)} is invalid; "
                          f"allowed: a number from {lo:g} to {hi:g}")
    return float(value)


def _parse_station(path: Path, section: str, table: dict, name_default: str,
                   mask_paths: dict[str, str] | None = None) -> Station:
    fields = {k: v for k, v in table.items() if not isinstance(v, dict)}  # [station.NAME]
    where = f"{path}: [{section}]"
    station = parse_station(fields, where, base_dir=path.parent, default_name=name_default)
    if "mask" in fields and mask_paths is not None:
        key = name_default if section != "station" else station.name
        mask_paths[key] = str(mask_file(fields["mask"], where, path.parent))
    return station


def _parse_rotator(path: Path, name: str, table: dict, mains_hz: int) -> RotatorSpec:  # noqa: C901
    section = f"rotator.{name}"
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: rotator = {_toml_value(table)}: use a [rotator.NAME] "
                          f"table")
    table = dict(table)
    base_name = table.pop("preset", None)
    hz = table.pop("mains_hz", mains_hz)
    if hz not in (50, 60) or isinstance(hz, bool):
        raise ConfigError(f"{path}: [{section}] mains_hz = {_toml_value(hz)} is invalid; "
                          f"allowed: 50 or 60")
    if base_name is not None:
        if not isinstance(base_name, str):
            raise ConfigError(f"{path}: [{section}] preset = {_toml_value(base_name)} is "
                              f"invalid; allowed: {', '.join(PRESETS)}")
        try:
            base = preset(base_name, hz)
        except ConfigError as e:
            raise ConfigError(f"{path}: [{section}] preset: {e}") from None
    else:
        base = None
    changes: dict[str, Any] = {}
    az_only = table.pop("az_only", False)
    if not isinstance(az_only, bool):
        raise ConfigError(f"{path}: [{section}] az_only = {_toml_value(az_only)} is invalid; "
                          f"allowed: true or false")
    if az_only:
        changes.update(el_max_deg=None, el_rate_deg_s=None)
    for key, value in table.items():
        if key not in _ROTATOR_FIELDS:
            raise ConfigError(f"{path}: [{section}] unknown key {key!r}; allowed keys: "
                              f"preset, mains_hz, az_only, {', '.join(_ROTATOR_FIELDS)}")
        if key in ("el_max_deg", "el_rate_deg_s") and (value is False or value == "none"):
            value = None  # azimuth-only rotator
        elif key == "az_speed_rates_deg_s":
            if not isinstance(value, list):
                raise ConfigError(f"{path}: [{section}] {key} = {_toml_value(value)} is "
                                  f"invalid; allowed: a list of rates, e.g. [1.5, 3, 4.5, 6]")
            value = tuple(value)
        elif key in ("description",):
            if not isinstance(value, str):
                raise ConfigError(f"{path}: [{section}] {key} must be a string")
        elif key == "controller_maps_south":
            if not isinstance(value, bool):
                raise ConfigError(f"{path}: [{section}] {key} = {_toml_value(value)} is "
                                  f"invalid; allowed: true or false")
        elif isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{path}: [{section}] {key} = {_toml_value(value)} is invalid; "
                              f"allowed: a number")
        changes[key] = value
    try:
        if base is not None:
            return base.with_(name=name, **changes)
        return RotatorSpec(name=name, **changes)
    except ConfigError as e:
        raise ConfigError(f"{path}: [{section}] {e}") from None
    except TypeError as e:  # a value of the wrong kind deep inside validation
        raise ConfigError(f"{path}: [{section}] {e}") from None


def _parse_tracking(path: Path, table: dict) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key not in TRACKING_KEYS:
            raise ConfigError(f"{path}: [tracking] unknown key {key!r}; allowed keys: "
                              f"{', '.join(TRACKING_KEYS)}")
        types, allowed = TRACKING_KEYS[key]
        ok = isinstance(value, types) and not (isinstance(value, bool) and bool not in types)
        if ok and key in _TRACKING_RANGES:
            lo, hi = _TRACKING_RANGES[key]
            ok = math.isfinite(value) and lo <= value <= hi
        if ok and key == "mains_hz":
            ok = value in (50, 60)
        if not ok:
            raise ConfigError(f"{path}: [tracking] {key} = {_toml_value(value)} is invalid; "
                              f"allowed: {allowed}")
        out[key] = value
    return out


def _priority(path: Path, key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not (
            0 <= value <= MAX_PRIORITY):
        raise ConfigError(f"{path}: [schedule] {key} = {_toml_value(value)} is invalid; "
                          f"allowed: a whole number from 0 (never) to {MAX_PRIORITY}")
    return value


def _priorities(path: Path, key: str, value: Any) -> dict[str, int]:
    """``{ "NAME" = N, ... }`` or ``["NAME=N", "NAME", ...]`` (no ``=N``: priority 1)."""
    out: dict[str, int] = {}
    if isinstance(value, dict):
        for name, level in value.items():
            if not name.strip():
                raise ConfigError(f"{path}: [schedule] {key} has an empty name")
            out[name.strip()] = _priority(path, f"{key}.{_key(name)}", level)
        return out
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{path}: [schedule] {key} = {_toml_value(value)} is invalid; "
                          f'allowed: a table {{ "NAME" = N }} or a list ["NAME=N", "NAME"]')
    for item in value:
        name, sep, level = item.rpartition("=")
        if not sep or not level.strip().lstrip("-").isdigit():
            name, level = item, "1"  # no "=N": a name (which may itself hold "=")
        name = name.strip()
        if not name:
            raise ConfigError(f"{path}: [schedule] {key} item {_toml_value(item)} is invalid; "
                              f'allowed: "NAME=N" or "NAME"')
        out[name] = _priority(path, f"{key} item {_toml_value(item)}", int(level))
    return out


def _schedule_value(path: Path, key: str, value: Any) -> Any:
    if key in ("targets", "groups"):
        return _priorities(path, key, value)
    if key in _SCHEDULE_RANGES:
        return _number(path, "schedule", key, value, *_SCHEDULE_RANGES[key])
    if key == "mode":
        if value not in SCHEDULE_MODES:
            raise ConfigError(f"{path}: [schedule] mode = {_toml_value(value)} is invalid; "
                              f"allowed: {', '.join(SCHEDULE_MODES)}")
        return value
    if key == "park":
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: [schedule] park = {_toml_value(value)} is invalid; "
                              f"allowed: true or false")
        return value
    if not isinstance(value, list) or not value or not all(
            isinstance(v, str) and v.strip() for v in value):
        raise ConfigError(f"{path}: [schedule] sources = {_toml_value(value)} is invalid; "
                          f'allowed: a list of group names or URLs, e.g. ["weather", "amateur"]')
    return tuple(v.strip() for v in value)


def _parse_schedule(path: Path, table: Any) -> ScheduleSettings:
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: schedule must be a [schedule] table")
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in SCHEDULE_KEYS:
            raise ConfigError(f"{path}: [schedule] unknown key {key!r}; allowed keys: "
                              f"{', '.join(SCHEDULE_KEYS)}")
        values[key] = _schedule_value(path, key, value)
    settings = ScheduleSettings(**values)
    if not any(settings.targets.values()) and not any(settings.groups.values()):
        raise ConfigError(f"{path}: [schedule] names nothing to track; give targets = "
                          f'{{ "ISS (ZARYA)" = 1 }} and/or groups = {{ weather = 1 }} with a '
                          f"priority above 0")
    return settings


# One guard per section of the file, each with its own message.
def parse_config(data: dict, path: Path) -> Config:  # noqa: C901
    """Validate a parsed TOML document into a :class:`Config`."""
    known = {"station", "rotator", "tracking", "schedule"}
    for key in data:
        if key not in known:
            raise ConfigError(f"{path}: unknown section or key {key!r}; allowed sections: "
                              f"[station], [station.NAME], [rotator.NAME], [tracking], "
                              f"[schedule]")
    tracking = _parse_tracking(path, data.get("tracking", {}))
    mains_hz = int(tracking.get("mains_hz", 60))

    stations: dict[str, Station] = {}
    mask_paths: dict[str, str] = {}
    station_table = data.get("station", {})
    if not isinstance(station_table, dict):
        raise ConfigError(f"{path}: station must be a [station] table")
    has_top = any(not isinstance(v, dict) for v in station_table.values())
    top = None
    if has_top:
        top = _parse_station(path, "station", station_table, "home", mask_paths)
        stations[top.name] = top
    for name, sub in station_table.items():
        if isinstance(sub, dict):
            st = _parse_station(path, f"station.{name}", sub, name, mask_paths)
            stations[name] = st
    chosen = tracking.get("station")
    if chosen:
        if chosen not in stations:
            raise ConfigError(f"{path}: [tracking] station = {_toml_value(chosen)} is "
                              f"invalid; allowed: {', '.join(stations) or 'define a station'}")
        default = stations[chosen]
    elif top is not None:
        default = top
    elif stations:
        default = next(iter(stations.values()))
    else:
        default = None

    rotators = dict(PRESETS)
    rot_table = data.get("rotator", {})
    if not isinstance(rot_table, dict):
        raise ConfigError(f"{path}: rotator must be [rotator.NAME] tables")
    for name, table in rot_table.items():
        rotators[name] = _parse_rotator(path, name, table, mains_hz)
    rot_name = tracking.get("rotator")
    if rot_name and rot_name not in rotators and rot_name.lower() not in {
            k.lower() for k in rotators}:
        raise ConfigError(f"{path}: [tracking] rotator = {_toml_value(rot_name)} is invalid; "
                          f"allowed: {', '.join(rotators)}")
    schedule = _parse_schedule(path, data["schedule"]) if "schedule" in data else None
    return Config(station=default or DEFAULT_STATION, stations=stations, rotators=rotators,
                  tracking=tracking, path=path, station_is_default=default is None,
                  mask_paths=mask_paths, schedule=schedule)


def load_config(path: str | Path | None = None) -> Config:
    """Read the config file. An explicit ``path`` must exist; the default location may not."""
    explicit = path is not None or bool(os.environ.get(ENV_VAR))
    p = Path(path).expanduser() if path is not None else default_config_path()
    if not p.exists():
        if explicit:
            raise with_advice(ConfigError, f"config file {p} does not exist",
                              "; create it with write_template(path)")
        return Config()
    return parse_config(_read_toml(p), p)


TEMPLATE = """\
# tracker config file (TOML). Written by `tracker config init`; edit freely.
# Command-line flags (--lat, --lon, --min-el, --station, ...) override these values.

[station]
name = "home"
{position}
alt_m = {alt_m}             # metres above the WGS84 ellipsoid (-500 to 9000)
min_el_deg = 0.0        # passes count from this elevation up (-5 to 90)
# mask = "horizon.txt"  # optional horizon mask: 'azimuth_deg elevation_deg' per line,
#                       # linear in between; relative paths are next to this file

# More stations: choose one with --station portable (or [tracking] station = "portable").
# [station.portable]
# lat_deg = 51.5
# lon_deg = -0.1
# min_el_deg = 5.0

[tracking]
rotator = "home"        # a [rotator.NAME] below, or a preset: G-5500, generic-k3ng
# protocol = "gs232b"   # controller dialect
# port = "/dev/ttyUSB0" # or socket://host:port, rfc2217://host:port
# baudrate = 9600
# park_after_pass = true
# deadband_deg = 4.0
# mains_hz = 60         # 50 Hz mains turns Yaesu AC motors 5/6 as fast

# Station mode (`tracker station run`): what to track unattended, by priority (higher wins
# an overlap; 0 = never). Names as `tracker passes` takes them, NORAD ids, or "Sun"/"Moon".
# [schedule]
# targets = {{ "ISS (ZARYA)" = 3, "NOAA 20" = 2 }}   # or a list: ["ISS (ZARYA)=3", "SO-50"]
# groups = {{ weather = 1 }}    # every object of an element group, at this priority
# min_max_el_deg = 10.0       # passes lower than this are not scheduled
# mode = "auto"               # "stream", "table" (step tables) or "auto"
# park = true                 # park between passes (false: stay)
# refresh_h = 12.0            # fresh elements every ... hours (at least 2)
# horizon_h = 24.0            # how far ahead the schedule reaches
# settle_s = 60.0             # time kept free between passes (pre-position, table upload)
# sources = ["weather", "stations"]   # element groups to download (default: the groups)

# A rotator: start from a preset and override any field.
[rotator.home]
preset = "G-5500"
# az_span_deg = 450       # 360 to 450
# stop_bearing_deg = 0    # 0 = north stop, 180 = south stop
# el_max_deg = 180        # 90 or 180 (flip); "none" for azimuth-only
# az_rate_deg_s = 6.2
# el_rate_deg_s = 2.7
# deadband_deg = 4.0
"""


_PLACEHOLDER_POSITION = (
    f"lat_deg = {DEFAULT_STATION.lat_deg}          # PLACEHOLDER: degrees north (-90 to 90)\n"
    f"lon_deg = {DEFAULT_STATION.lon_deg}           # PLACEHOLDER: degrees east; west is "
    "negative\n"
    '# locator = "JO22xb"    # or a Maidenhead locator instead of lat_deg/lon_deg')


def template_text(lat_deg: float | None = None, lon_deg: float | None = None,
                  alt_m: float = 0.0, locator: str | None = None) -> str:
    """:data:`TEMPLATE` with the station's position: a locator, lat/lon, or the placeholder
    (which commands keep pointing out until it is replaced)."""
    if locator is not None:
        locator_lat_lon(locator)  # a bad locator is refused before anything is written
        position = (f"locator = {_toml_value(locator.strip())}   # Maidenhead, centre of "
                    "the square")
    elif lat_deg is not None and lon_deg is not None:
        Station(lat_deg=lat_deg, lon_deg=lon_deg)  # range checks
        position = (f"lat_deg = {lat_deg!r}          # degrees north (-90 to 90)\n"
                    f"lon_deg = {lon_deg!r}           # degrees east (-180 to 180); west is "
                    "negative")
    else:
        position = _PLACEHOLDER_POSITION
    Station(alt_m=alt_m)
    return TEMPLATE.format(position=position, alt_m=float(alt_m))


def write_template(path: Path, force: bool = False, text: str | None = None) -> Path:
    """Write ``text`` (default: :func:`template_text`, the placeholder station) to ``path``;
    refuses to overwrite unless ``force``."""
    from platformdirs import user_config_dir

    from tracker.files import write_atomic

    text = template_text() if text is None else text

    path = Path(path).expanduser()
    label = "config file"
    if path.parent != Path(user_config_dir("tracker")):
        # Any other folder is the user's: like every output, a missing one is refused (a
        # typo in the path must not grow a folder tree); the tool's own config folder is
        # made on first use.
        return write_atomic(path, text, force=force, label=label)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise with_advice(ConfigError, f"{label} {path}: a part of the folder {path.parent} "
                          "is a file, not a folder", "; choose another path") from None
    except OSError as e:
        raise with_advice(ConfigError, f"{label} {path}: cannot create folder {path.parent} "
                          f"({e.strerror})", "; choose another path") from None
    return write_atomic(path, text, force=force, label=label)
