"""The inputs of a batch run: the stations file, and the element sets SGP4 is given.

Stations file: the station schema of the config file (:func:`tracker.station.parse_station`:
``name``, ``lat_deg``, ``lon_deg``, ``alt_m``, ``min_el_deg``, ``mask``; the short ``lat``,
``lon``, ``alt``, ``min_el`` are read too) as CSV (columns ``name,lat_deg,lon_deg[,alt_m[,
min_el_deg]]`` without a header row, or the columns a header row names; ``#`` comments
allowed) or as TOML with one ``[[station]]`` table per station. Errors name ``file:line``.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable
from pathlib import Path

from tle.textfile import read_text_file
from tracker.errors import ConfigError
from tracker.station import Station, parse_station


def satrecs_of(elements: Iterable) -> tuple[list, list[str]]:
    """(Satrec list, name list) from ``tle`` ElementSets (anything with ``.satrec()``)."""
    elements = list(elements)
    return [e.satrec() for e in elements], [e.name for e in elements]


def split_by_epoch(elements: Iterable, start_s: float, end_s: float) -> tuple[list, list]:
    """(usable, too far): element sets whose epoch lies within
    :data:`~tracker.targets.MAX_PROPAGATION_DAYS` of every time in ``[start_s, end_s]``, and
    the rest (SGP4 far from the epoch gives passes that look real and are not)."""
    from tracker.targets import MAX_PROPAGATION_DAYS

    limit_s = MAX_PROPAGATION_DAYS * 86400.0
    near, far = [], []
    for es in elements:
        epoch_s = es.epoch.timestamp()
        ok = abs(start_s - epoch_s) <= limit_s and abs(end_s - epoch_s) <= limit_s
        (near if ok else far).append(es)
    return near, far


def _station(path: Path, line_no: int, values: dict) -> Station:
    return parse_station(values, f"{path}:{line_no}:", base_dir=path.parent, from_text=True)


def _load_csv(path: Path, text: str) -> list[Station]:
    stations = []
    rows = [(i, line) for i, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("#")]
    header = ["name", "lat_deg", "lon_deg", "alt_m", "min_el_deg"]
    for n, (line_no, line) in enumerate(rows):
        cells = [c.strip() for c in next(csv.reader(io.StringIO(line)))]
        if n == 0 and cells and cells[0].lower() == "name":
            header = [c.lower() for c in cells]
            continue
        if not (3 <= len(cells) <= len(header)):
            raise ConfigError(f"{path}:{line_no}: expected 'name,lat_deg,lon_deg[,alt_m[,"
                              f"min_el_deg]]', got {line.strip()!r}")
        stations.append(_station(path, line_no, dict(zip(header, cells, strict=False))))
    return stations


def _load_toml(path: Path, text: str) -> list[Station]:
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: {e}") from None
    except RecursionError:   # the parser nests one call per [ : a stations file has two levels
        raise ConfigError(f"{path}: TOML nested too deeply to be a stations file; expected "
                          "[[station]] tables with name, lat_deg, lon_deg, alt_m") from None
    tables = data.get("station")
    if not isinstance(tables, list):
        raise ConfigError(f"{path}: expected [[station]] tables with name, lat_deg, lon_deg, "
                          f"alt_m")
    lines = text.splitlines()
    marks = [i for i, line in enumerate(lines, 1) if line.strip() == "[[station]]"]
    return [_station(path, marks[i] if i < len(marks) else 0, table)
            for i, table in enumerate(tables)]


def load_stations(path: str | Path) -> list[Station]:
    """Read a stations file (CSV or TOML by extension/content); names must be unique."""
    path = Path(path)
    text = read_text_file(path, "stations file", ConfigError,
                          hint="a stations file is CSV or TOML")
    is_toml = path.suffix.lower() == ".toml" or "[[station]]" in text
    stations = _load_toml(path, text) if is_toml else _load_csv(path, text)
    if not stations:
        raise ConfigError(f"{path}: no stations; add lines like 'Delft,52.0,4.37,10'")
    seen: set[str] = set()
    for s in stations:
        if s.name in seen:
            raise ConfigError(f"{path}: station name {s.name!r} appears twice")
        seen.add(s.name)
    return stations
