"""Shared command-line options: station, config, catalogue, target and "as of" time.

Every command that needs a station, a target or the time builds on these helpers so the
flags mean the same everywhere::

    add_station_args(parser)    --config FILE --station NAME --lat --lon --alt --min-el --mask
    add_target_args(parser)     --tle FILE (repeatable) --group G
    add_time_args(parser)       --at UTC-ISO (run "as of" a fixed time)

``config_from_args`` / ``station_from_args`` / ``catalog_from_args`` / ``target_from_args`` /
``clock_from_args`` turn the parsed flags into values. Flags override the config file.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable
from dataclasses import replace
from datetime import datetime, timezone
from typing import TYPE_CHECKING, TypeVar

from tracker.errors import ConfigError

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.clock import Clock
    from tracker.config import Config
    from tracker.mount import RotatorSpec
    from tracker.station import Station
    from tracker.stream import StreamSettings
    from tracker.targets import Target


E = TypeVar("E", bound=Exception)


def in_flag_terms(error: E, terms: Iterable[tuple[str, str]]) -> E:
    """``error`` worded for the command line: each Python term of its advice (a parameter, a
    function; see :class:`~tle.errors.AdvisedError`) replaced, in order, by the flag or
    command that does the same. The problem part is never touched; other errors are kept."""
    advice = getattr(error, "advice", "")
    if advice:
        for python_term, cli_term in terms:
            advice = advice.replace(python_term, cli_term)
        error.advise(advice)  # type: ignore[attr-defined]
    return error


def flag_first(error: E, name: str, flag: str) -> E:
    """``error`` worded for the command line: a library message that starts with ``name`` (a
    parameter, or the function the flag turns on) starts with ``flag`` instead."""
    text = str(error)
    if text.startswith(name + " "):
        error.args = (flag + text[len(name):],)
    return error


def protocol_help(default: str = "gs232b") -> str:
    """``--protocol``'s help: every name the registry knows, with what it drives."""
    from tracker.controllers import CONTROLLERS

    parts = []
    for entry in CONTROLLERS:
        for n in entry.names:
            note = " (default)" if n == default else ""
            if entry.dual_azimuth:
                note += f" (antenna {entry.names.index(n) + 1})"
            if entry.port_hint:
                note += " (--port host:port)"
            parts.append(n + note)
    return "controller protocol: " + ", ".join(parts)


def add_config_arg(parser: argparse.ArgumentParser) -> None:
    """``--config FILE`` alone (for commands that need no station)."""
    if any("--config" in a.option_strings for a in parser._actions):
        return
    parser.add_argument("--config", metavar="FILE",
                        help="config file (default: $TRACKER_CONFIG or the user config dir)")


def add_rotator_args(parser: argparse.ArgumentParser) -> None:
    """``--rotator NAME`` and ``--mains-hz``: one spelling for every command."""
    parser.add_argument("--rotator", metavar="NAME",
                        help="a preset (G-5500, G-1000DXA, ...) or a [rotator.NAME] config "
                             "section (default: config [tracking] rotator, else G-5500)")
    parser.add_argument("--mains-hz", "--mains", type=int, choices=(50, 60), dest="mains_hz",
                        help="mains frequency of a preset's AC motors (50 Hz turns them 5/6 "
                             "as fast; default: config [tracking] mains_hz, else 60)")


def rotator_from_args(args: argparse.Namespace, name: str | None = None) -> RotatorSpec:
    """The rotator the command drives: ``name`` or ``--rotator``, else the config's, else G-5500.

    A ``[rotator.NAME]`` section carries its own rates, so ``--mains-hz`` is refused for it
    rather than silently ignored.
    """
    from tracker.mount import preset

    config = config_from_args(args)
    name = name or getattr(args, "rotator", None) or config.tracking.get("rotator") or "G-5500"
    mains_hz = getattr(args, "mains_hz", None)
    if mains_hz is None:
        return config.rotator(name)
    if config.user_rotator(name) is not None:
        raise ConfigError(f"--mains-hz applies to the presets only; for [rotator.{name}] set "
                          f"mains_hz = {mains_hz} in that section of the config file")
    return preset(name, mains_hz)


def add_station_args(parser: argparse.ArgumentParser) -> None:
    """Station options; each overrides the matching key of the config file's [station]."""
    add_config_arg(parser)
    g = parser.add_argument_group("station (overrides the config file)")
    g.add_argument("--station", metavar="NAME",
                   help="use the [station.NAME] section of the config file")
    g.add_argument("--lat", type=float, metavar="DEG", help="latitude, degrees north")
    g.add_argument("--lon", type=float, metavar="DEG", help="longitude, degrees east")
    g.add_argument("--alt", type=float, metavar="M", help="altitude above the ellipsoid, m")
    g.add_argument("--locator", metavar="LOC",
                   help="Maidenhead locator (JO22, JO22xb, ...) instead of --lat/--lon: the "
                        "centre of the square")
    g.add_argument("--min-el", type=float, metavar="DEG", dest="min_el",
                   help="minimum elevation, degrees (the horizon mask adds to it)")
    g.add_argument("--mask", metavar="FILE",
                   help="horizon mask file: 'azimuth_deg elevation_deg' per line")


def add_target_args(parser: argparse.ArgumentParser) -> None:
    """Element-source options: extra TLE/OMM files and a catalogue group."""
    g = parser.add_argument_group("elements")
    g.add_argument("--tle", action="append", default=[], metavar="FILE",
                   help="TLE/3LE/OMM file to use instead of the cached/bundled catalogue "
                        "(repeatable)")
    g.add_argument("--group", metavar="G",
                   help="catalogue group (e.g. amateur, weather, stations, visual)")


def check_baud_arg(args: argparse.Namespace) -> None:
    """Refuse an impossible ``--baud`` (0, negative, beyond what a port takes) up front, so a
    dry run or a simulation refuses it as the real port would."""
    from tracker.transport import check_baud

    baud = getattr(args, "baud", None)
    if baud is not None:
        check_baud(baud, "--baud")


def check_number_arg(args: argparse.Namespace, dest: str, lo: float, hi: float,
                     unit: str = "") -> None:
    """Refuse ``args.<dest>`` unless it is a finite number in ``[lo, hi]`` (None = not
    given, allowed); the message names the flag and the range."""
    import math

    value = getattr(args, dest, None)
    if value is None:
        return
    if not (math.isfinite(value) and lo <= value <= hi):
        flag = "--" + dest.replace("_", "-")
        raise ConfigError(f"{flag} {value:g} is invalid; allowed: {lo:g} to {hi:g}"
                          f"{' ' + unit if unit else ''}")


def add_time_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--at", metavar="UTC",
                        help="run as of this UTC time instead of now, e.g. 2026-08-23T12:00Z")


# Times a command may run "as of": the span of the JPL DE421 ephemeris (Sun, Moon) and far
# wider than any element set reaches; also keeps window arithmetic clear of datetime's limits.
AT_YEARS = (1900, 2100)


def parse_utc(text: str) -> datetime:
    """Parse an ISO-8601 time (``Z``/offset optional; no offset means UTC) to aware UTC,
    within :data:`AT_YEARS`."""
    raw = text.strip()
    if not raw:
        raise ConfigError("empty time; use ISO-8601 UTC such as 2026-08-23T12:00:00Z")
    from tracker.timescale import parse_iso_utc

    s = raw.replace(" ", "T", 1) if "T" not in raw and " " in raw else raw
    try:
        t = parse_iso_utc(s)
    except ValueError:
        raise ConfigError(f"cannot read the time {text!r}; use ISO-8601 UTC such as "
                          f"2026-08-23T12:00:00Z or '2026-08-23 12:00'") from None
    if not AT_YEARS[0] <= t.year <= AT_YEARS[1]:
        raise ConfigError(f"the time {text!r} is outside {AT_YEARS[0]}-{AT_YEARS[1]}, the "
                          f"years this tool can compute for; give a time in that range")
    try:
        return t.astimezone(timezone.utc)
    except OverflowError:
        raise ConfigError(f"the time {text!r} is out of range") from None


def clock_from_args(args: argparse.Namespace, manual: bool = False) -> Clock:
    """The clock for a command: ``--at`` starts a simulated clock there, else real time.

    ``manual=True`` gives a :class:`~tracker.clock.ManualClock` that stands still (for
    commands that only read the time once, so output is exactly reproducible); otherwise a
    :class:`~tracker.clock.SimClock` at speed 1 that runs on from ``--at``.
    """
    from tracker.clock import ManualClock, SimClock, SystemClock

    at = getattr(args, "at", None)
    if at is None:
        return SystemClock()
    start = parse_utc(at)
    return ManualClock(start) if manual else SimClock(start, speed=1.0)


def config_from_args(args: argparse.Namespace) -> Config:
    """The effective config (cached on ``args``): ``--config``, ``$TRACKER_CONFIG`` or default."""
    cached = getattr(args, "_config", None)
    if cached is not None:
        return cached
    from pathlib import Path

    from tracker.config import default_config_path, load_config

    path = getattr(args, "config", None)
    try:
        config = load_config(path)
    except ConfigError as e:
        p = Path(path).expanduser() if path is not None else default_config_path()
        raise in_flag_terms(e, [("write_template(path)",
                                 f"`tracker config init --config {p}`")]) from None
    try:
        args._config = config
    except AttributeError:  # pragma: no cover - exotic namespaces
        pass
    return config


def station_from_args(args: argparse.Namespace, quiet: bool = False) -> Station:
    """The station: config file ([station] or [station.NAME]) overridden by flags."""
    from tracker.station import HorizonMask, position_name

    config = config_from_args(args)
    station = config.station_named(getattr(args, "station", None))
    changes: dict = {}
    for flag, key in (("lat", "lat_deg"), ("lon", "lon_deg"), ("alt", "alt_m"),
                      ("min_el", "min_el_deg")):
        value = getattr(args, flag, None)
        if value is not None:
            changes[key] = float(value)
    locator = getattr(args, "locator", None)
    if locator is not None:
        changes.update(_locator_position(locator, changes))
    if getattr(args, "mask", None):
        changes["mask"] = HorizonMask.load(args.mask)
    if config.station_is_default and not getattr(args, "station", None) and (
            "lat_deg" in changes or "lon_deg" in changes):
        changes["name"] = (locator.strip() if locator is not None else
                           position_name(changes.get("lat_deg", station.lat_deg),
                                         changes.get("lon_deg", station.lon_deg)))
    if changes:
        try:
            station = replace(station, **changes)
        except ConfigError as e:
            raise ConfigError(f"command line: {e}") from None
    if (config.station_is_placeholder and not getattr(args, "station", None)
            and "lat_deg" not in changes and not quiet):
        where = ("no station configured" if config.station_is_default else
                 f"the station in {config.path} is still the placeholder")
        print(f"tracker: note: {where}, using {station.name} (lat {station.lat_deg}, lon "
              f"{station.lon_deg}); run `tracker config init --locator LOC --force` (or "
              f"--lat/--lon), or pass --lat/--lon or --locator", file=sys.stderr)
    return station


def _locator_position(locator: str, changes: dict) -> dict[str, float]:
    """``--locator``'s position, refused together with --lat/--lon."""
    from tracker.station import locator_lat_lon

    if "lat_deg" in changes or "lon_deg" in changes:
        raise ConfigError("give either --locator or --lat/--lon, not both")
    try:
        lat_deg, lon_deg = locator_lat_lon(locator)
    except ConfigError as e:
        raise ConfigError(f"--locator: {e}") from None
    return {"lat_deg": lat_deg, "lon_deg": lon_deg}


def catalog_from_args(args: argparse.Namespace):
    """The element catalogue: ``--tle`` files if given, else the cache/bundled default.

    With ``--group G`` the catalogue is narrowed to that group.
    """
    cached = getattr(args, "_catalog", None)
    if cached is not None:
        return cached
    from tle.catalog import Catalog

    def warn(message: str) -> None:  # a broken set is skipped with one line naming file:line
        print(f"tracker: warning: {message}", file=sys.stderr)

    files = list(getattr(args, "tle", None) or [])
    catalog = (Catalog.load(files, on_warning=warn) if files
               else Catalog.default(on_warning=warn))
    group = getattr(args, "group", None)
    if group:
        catalog = catalog.group(group)
    try:
        args._catalog = catalog
    except AttributeError:  # pragma: no cover
        pass
    return catalog


def warn_element_age(targets: Iterable[object], now: datetime) -> None:
    """The element-age warnings of every command that uses elements, on stderr: one line per
    stale (or, against ``--at``, future) set, or one summary for many. ``targets`` are
    targets (only satellites have elements) or element sets. Sets beyond the propagation
    limit are left out: they are refused with their own line when used."""
    from tle.catalog import age_warnings
    from tracker.targets import MAX_PROPAGATION_DAYS

    sets = []
    for t in targets:
        es = getattr(t, "elements", t)
        if hasattr(es, "age_days") and abs(es.age_days(now)) <= MAX_PROPAGATION_DAYS:
            sets.append(es)
    for w in age_warnings(sets, now):
        # The loud text already starts with "WARNING:".
        label = "" if w.startswith("WARNING") else "warning: "
        print(f"tracker: {label}{w}", file=sys.stderr)


def target_from_args(name: str, args: argparse.Namespace) -> Target:
    """Resolve ``name``: registered resolvers (Sun, Moon, ...) first, then the catalogue."""
    from tracker.targets import resolve_target

    return resolve_target(name, lambda: catalog_from_args(args))


def speed_arg(text: str) -> float:
    """``--speed``: a simulation's factor, or ``max`` for virtual time (``math.inf``)."""
    import math

    if str(text).strip().lower() == "max":
        return math.inf
    try:
        speed = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or 'max'") from None
    if not math.isfinite(speed):     # 'inf' is not 'max': a typo must not mean virtual time
        raise argparse.ArgumentTypeError(f"{text} is invalid; give a number or max")
    return speed


def stream_settings(config: Config, spec: RotatorSpec, *, deadband_deg: float | None = None,
                    cycle_s: float | None = None, park: bool | None = None) -> StreamSettings:
    """The live loop's settings: the flags (``--deadband``, ``--cycle``, ``--park/--stay``)
    where given, else the config's ``[tracking]``, else the rotator's deadband and 0.5 s."""
    from tracker.stream import StreamSettings

    tr = config.tracking
    deadband = deadband_deg if deadband_deg is not None else tr.get(
        "deadband_deg", spec.deadband_deg)
    if not (0.0 <= deadband <= 30.0):
        raise ConfigError(f"--deadband {deadband} is invalid; allowed: 0 to 30 degrees")
    cycle = cycle_s if cycle_s is not None else tr.get("update_interval_s", 0.5)
    if not (0.05 <= cycle <= 60.0):
        raise ConfigError(f"--cycle {cycle} is invalid; allowed: 0.05 to 60 seconds")
    park = park if park is not None else tr.get("park_after_pass", True)
    return StreamSettings(deadband_deg=float(deadband), cycle_s=float(cycle),
                          park_after_pass=bool(park))
