"""Ground station: position, minimum elevation and an optional horizon mask; Maidenhead
locators (the one parser, for the config file, the stations files and the flags).

Also the one station schema: :func:`parse_station` reads a station from a table of
``name``, ``lat_deg``, ``lon_deg``, ``alt_m``, ``min_el_deg`` and ``mask`` (a horizon mask
file), for the config file's ``[station]`` sections and the batch stations files alike.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tle.textfile import read_text_file
from tracker.errors import ConfigError


@dataclass(frozen=True)
class HorizonMask:
    """Piecewise-linear minimum elevation as a function of true bearing (wraps at 360).

    ``az_deg`` is sorted in [0, 360); ``min_el_deg`` the obstruction elevation there.
    """

    az_deg: tuple[float, ...]
    min_el_deg: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.az_deg) != len(self.min_el_deg) or not self.az_deg:
            raise ConfigError("horizon mask needs at least one 'azimuth elevation' point")
        if any(not (0.0 <= a < 360.0) for a in self.az_deg):
            raise ConfigError("horizon mask azimuths must be in 0 to <360 degrees")
        if any(not (-5.0 <= e <= 90.0) for e in self.min_el_deg):
            raise ConfigError("horizon mask elevations must be in -5 to 90 degrees")
        if list(self.az_deg) != sorted(self.az_deg) or len(set(self.az_deg)) != len(
                self.az_deg):
            raise ConfigError("horizon mask azimuths must be strictly increasing")

    def min_el_at(self, az_deg):
        """Mask elevation at bearing(s) ``az_deg`` (scalar or array), linear between points."""
        az = np.mod(np.asarray(az_deg, dtype=float), 360.0)
        xp = np.asarray(self.az_deg)
        fp = np.asarray(self.min_el_deg)
        return np.interp(az, xp, fp, period=360.0)

    @classmethod
    def load(cls, path: str | Path) -> HorizonMask:
        """Read ``azimuth elevation`` pairs (space, tab or comma separated; ``#`` comments)."""
        path = Path(path)
        text = read_text_file(path, "horizon mask", ConfigError,
                              hint="a horizon mask is 'azimuth_deg elevation_deg' per line")
        points: dict[float, float] = {}
        for line_no, raw in enumerate(text.splitlines(), 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.replace(",", " ").split()
            try:
                if len(parts) != 2:
                    raise ValueError
                az, el = float(parts[0]), float(parts[1])
            except ValueError:
                raise ConfigError(f"{path}:{line_no}: expected 'azimuth_deg elevation_deg', "
                                  f"got {raw.strip()!r}") from None
            if not (0.0 <= az <= 360.0) or not (-5.0 <= el <= 90.0):
                raise ConfigError(f"{path}:{line_no}: azimuth must be 0-360 and elevation "
                                  f"-5-90, got {raw.strip()!r}")
            points[az % 360.0] = el
        if not points:
            raise ConfigError(f"{path}: horizon mask file has no points")
        az_sorted = sorted(points)
        return cls(tuple(az_sorted), tuple(points[a] for a in az_sorted))


# The station schema: field -> allowed range (numbers), plus name and mask.
STATION_RANGES: dict[str, tuple[float, float]] = {
    "lat_deg": (-90.0, 90.0), "lon_deg": (-180.0, 180.0), "alt_m": (-500.0, 9000.0),
    "min_el_deg": (-5.0, 90.0)}
STATION_FIELDS = ("name", *STATION_RANGES, "locator", "mask")
# Short spellings that stations files written for earlier versions use; read, never written.
STATION_ALIASES = {"lat": "lat_deg", "lon": "lon_deg", "alt": "alt_m", "min_el": "min_el_deg"}
_EXAMPLE = {"name": '"Delft"', "lat_deg": "52.0", "lon_deg": "4.4"}


@dataclass(frozen=True)
class Station:
    """A ground station. ``min_el_deg`` applies everywhere; the mask adds to it per bearing."""

    name: str = "station"
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    alt_m: float = 0.0
    min_el_deg: float = 0.0
    mask: HorizonMask | None = field(default=None)

    def __post_init__(self) -> None:
        for key, (lo, hi) in STATION_RANGES.items():
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value)
                    and lo <= value <= hi):
                raise ConfigError(f"station.{key} = {value!r} is out of range; allowed: "
                                  f"{lo:g} to {hi:g}")

    def horizon_at(self, az_deg):
        """The elevation below which the target counts as not visible, at bearing(s) az_deg."""
        if self.mask is None and isinstance(az_deg, float):   # the live loop's guard
            return float(self.min_el_deg)
        base = np.full(np.shape(az_deg), float(self.min_el_deg))
        if self.mask is None:
            return base if np.ndim(az_deg) else float(base)
        out = np.maximum(base, self.mask.min_el_at(az_deg))
        return out if np.ndim(az_deg) else float(out)

    def topos(self):
        """The skyfield geographic position of the station (WGS84)."""
        from skyfield.toposlib import wgs84

        return wgs84.latlon(self.lat_deg, self.lon_deg, elevation_m=self.alt_m)


def _shown(value: Any) -> str:
    return json.dumps(value, default=str)


def mask_file(value: Any, where: str, base_dir: Path | None) -> Path:
    """The horizon mask file a station's ``mask`` names (relative to ``base_dir``)."""
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{where} mask = {_shown(value)} is invalid; allowed: a path to a "
                          f"horizon mask file")
    path = Path(value).expanduser()
    return path if path.is_absolute() or base_dir is None else base_dir / path


def _station_number(key: str, field_name: str, value: Any, where: str,
                    from_text: bool) -> float:
    lo, hi = STATION_RANGES[field_name]
    number = value
    if from_text and isinstance(value, str):
        try:
            number = float(value)
        except ValueError:
            pass
    if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(
            number) or not lo <= number <= hi:
        raise ConfigError(f"{where} {key} = {_shown(number)} is invalid; allowed: a number "
                          f"from {lo:g} to {hi:g}")
    return float(number)


def _locator_fields(value: Any, values: Mapping[str, Any], where: str) -> dict[str, float]:
    """``lat_deg``/``lon_deg`` of a ``locator = "JO22xb"`` key (the centre of the square)."""
    keys = {STATION_ALIASES.get(str(k).strip().lower(), str(k).strip().lower()) for k in values}
    if keys & {"lat_deg", "lon_deg"}:
        raise ConfigError(f"{where} has both locator and lat_deg/lon_deg; keep one of them")
    if not isinstance(value, str):
        raise ConfigError(f"{where} locator = {_shown(value)} is invalid; allowed: a "
                          f"Maidenhead locator such as \"JO22xb\"")
    try:
        lat_deg, lon_deg = locator_lat_lon(value)
    except ConfigError as e:
        raise ConfigError(f"{where} {e}") from None
    return {"lat_deg": lat_deg, "lon_deg": lon_deg}


def parse_station(values: Mapping[str, Any], where: str, *, base_dir: Path | None = None,
                  default_name: str | None = None, from_text: bool = False) -> Station:
    """A :class:`Station` from a table of :data:`STATION_FIELDS` (or
    :data:`STATION_ALIASES`); ``where`` starts every error message (``file:line:`` or
    ``file: [section]``). ``mask`` is a horizon mask file relative to ``base_dir``;
    ``from_text`` accepts numbers written as text (CSV cells)."""
    kwargs: dict[str, Any] = {} if default_name is None else {"name": default_name}
    for key, value in values.items():
        name = STATION_ALIASES.get(str(key).strip().lower(), str(key).strip().lower())
        if name == "name":
            if not isinstance(value, str) or not value.strip():
                raise ConfigError(f"{where} name = {_shown(value)} is invalid; allowed: a "
                                  f"non-empty string")
            kwargs["name"] = value.strip()
        elif name in STATION_RANGES:
            kwargs[name] = _station_number(key, name, value, where, from_text)
        elif name == "mask":
            kwargs["mask"] = HorizonMask.load(mask_file(value, where, base_dir))
        elif name == "locator":
            kwargs.update(_locator_fields(value, values, where))
        else:
            raise ConfigError(f"{where} unknown key {key!r}; allowed keys: "
                              f"{', '.join(STATION_FIELDS)}")
    for key in ("name", "lat_deg", "lon_deg"):
        if key not in kwargs:
            raise ConfigError(f"{where} {key} is missing; add e.g. {key} = {_EXAMPLE[key]}"
                              + ("" if key == "name" else " (or a Maidenhead locator = "
                                                          "\"JO22xb\")"))
    return Station(**kwargs)


# Maidenhead: a field (18 x 18 letters A-R, 20 x 10 degrees), a square (digits, 2 x 1 degrees),
# a subsquare (24 x 24 letters a-x, 5 x 2.5 minutes), an extended square (digits, 30 x 15
# seconds). Each pair: (characters allowed, longitude size, latitude size) in degrees.
_LOCATOR_PAIRS = (("ABCDEFGHIJKLMNOPQR", 20.0, 10.0), ("0123456789", 2.0, 1.0),
                  ("ABCDEFGHIJKLMNOPQRSTUVWX", 2.0 / 24, 1.0 / 24),
                  ("0123456789", 2.0 / 240, 1.0 / 240))


def locator_lat_lon(locator: str) -> tuple[float, float]:
    """The centre of Maidenhead locator ``locator`` (2, 4, 6 or 8 characters, any case) as
    ``(lat_deg, lon_deg)``; :class:`ConfigError` says what is wrong with a bad one."""
    text = locator.strip().upper()
    if len(text) not in (2, 4, 6, 8):
        raise ConfigError(f"Maidenhead locator {locator!r} must have 2, 4, 6 or 8 characters "
                          "(e.g. JO22, JO22xb)")
    lon_deg, lat_deg = -180.0, -90.0
    for i in range(0, len(text), 2):
        allowed, lon_size, lat_size = _LOCATOR_PAIRS[i // 2]
        for ch, is_lat in ((text[i], False), (text[i + 1], True)):
            if ch not in allowed:
                kind = ("a letter A-R", "a digit", "a letter A-X", "a digit")[i // 2]
                raise ConfigError(f"Maidenhead locator {locator!r}: character {i + 1 + is_lat} "
                                  f"({ch!r}) must be {kind}")
            if is_lat:
                lat_deg += allowed.index(ch) * lat_size
            else:
                lon_deg += allowed.index(ch) * lon_size
    _allowed, lon_size, lat_size = _LOCATOR_PAIRS[len(text) // 2 - 1]
    return lat_deg + lat_size / 2.0, lon_deg + lon_size / 2.0


def position_name(lat_deg: float, lon_deg: float) -> str:
    """A readable name for a station known only by its position: ``52.0000N 4.4000E``."""
    return (f"{abs(lat_deg):.4f}{'N' if lat_deg >= 0 else 'S'} "
            f"{abs(lon_deg):.4f}{'E' if lon_deg >= 0 else 'W'}")
