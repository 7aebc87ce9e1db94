"""OMM (CCSDS Orbit Mean-Elements Message) in CelesTrak's JSON, CSV and XML forms.

Records are read with ``sgp4.omm`` (``parse_csv``, ``parse_xml``) or ``json``, checked field by
field here (so a bad record names its place and field), and turned into ``ElementSet`` values
whose ``satrec()`` goes through ``sgp4.omm.initialize``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import warnings
from collections.abc import Callable, Iterable, Mapping
from datetime import datetime, timezone
from typing import Any
from xml.etree.ElementTree import ParseError

from tle.element_set import ElementSet, WarningHandler
from tle.errors import TleError, TleFormatError, TleWarning

REQUIRED_FIELDS = (
    "OBJECT_NAME", "OBJECT_ID", "EPOCH", "MEAN_MOTION", "ECCENTRICITY", "INCLINATION",
    "RA_OF_ASC_NODE", "ARG_OF_PERICENTER", "MEAN_ANOMALY", "NORAD_CAT_ID", "BSTAR",
    "MEAN_MOTION_DOT",
)
# Fields sgp4.omm.initialize reads but which carry no orbit: sensible defaults when absent.
DEFAULTED_FIELDS = {
    "EPHEMERIS_TYPE": "0", "CLASSIFICATION_TYPE": "U", "ELEMENT_SET_NO": "999",
    "REV_AT_EPOCH": "0", "MEAN_MOTION_DDOT": "0",
}
_FLOAT_FIELDS = (
    "MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE", "ARG_OF_PERICENTER",
    "MEAN_ANOMALY", "BSTAR", "MEAN_MOTION_DOT", "MEAN_MOTION_DDOT",
)
# An orbit grazing the Earth's surface goes round about 17.8 times a day; more is no orbit.
MAX_MEAN_MOTION_REV_DAY = 20.0
# Element sets exist from Sputnik on; a TLE's two-digit year reaches 2056.
EPOCH_YEARS = (1957, 2100)
_INT_FIELDS = ("NORAD_CAT_ID", "EPHEMERIS_TYPE", "ELEMENT_SET_NO", "REV_AT_EPOCH")


def _normalise_epoch(text: str) -> str:
    # sgp4.omm wants %Y-%m-%dT%H:%M:%S.%f exactly: accept a trailing Z or whole seconds too.
    text = text.strip().removesuffix("Z")
    if "." not in text:
        text += ".000000"
    return text


def _check_numbers(fields: Mapping[str, str],
                   fault: Callable[[str], TleFormatError]) -> None:
    """Every float field a finite number and every int field a whole number, else ``fault``."""
    for key in _FLOAT_FIELDS:
        try:
            value = float(fields[key])
        except ValueError:
            raise fault(f"{key} should be a number, found {fields[key]!r}") from None
        if not math.isfinite(value):
            raise fault(f"{key} should be a finite number, found {fields[key]!r}")
    for key in _INT_FIELDS:
        try:
            int(fields[key])
        except ValueError:
            raise fault(f"{key} should be a whole number, found {fields[key]!r}") from None


def omm_to_element_set(record: Mapping[str, Any], source: str = "<string>",
                       record_no: int = 0, where: str = "record") -> ElementSet:
    """Check one OMM record and wrap it as an ``ElementSet`` (``line1``/``line2`` None)."""
    name = str(record.get("OBJECT_NAME") or "").strip()
    place = f"{source}:{where} {record_no}" + (f" ({name!r})" if name else "")

    def fault(what: str) -> TleFormatError:
        return TleFormatError(f"{place}: {what}", source=source, line_no=record_no)

    missing = [key for key in REQUIRED_FIELDS if record.get(key) in (None, "")]
    if missing:
        raise fault(f"missing OMM field(s) {', '.join(missing)} (CelesTrak names: "
                    f"{', '.join(REQUIRED_FIELDS)})")
    fields = {key: str(value).strip() for key, value in record.items() if value is not None}
    for key, default in DEFAULTED_FIELDS.items():
        if not fields.get(key):
            fields[key] = default
    fields["EPOCH"] = _normalise_epoch(fields["EPOCH"])
    _check_numbers(fields, fault)
    try:
        epoch = datetime.strptime(fields["EPOCH"], "%Y-%m-%dT%H:%M:%S.%f")
    except ValueError:
        raise fault(f"EPOCH should look like 2026-08-22T13:45:12.345678, "
                    f"found {fields['EPOCH']!r}") from None
    if not 0.0 <= float(fields["ECCENTRICITY"]) < 1.0:
        raise fault(f"ECCENTRICITY must be in [0, 1), found {fields['ECCENTRICITY']}")
    if not 0.0 < float(fields["MEAN_MOTION"]) <= MAX_MEAN_MOTION_REV_DAY:
        raise fault(f"MEAN_MOTION must be above 0 and at most {MAX_MEAN_MOTION_REV_DAY:g} "
                    f"rev/day (an orbit above the ground), found {fields['MEAN_MOTION']}")
    if not EPOCH_YEARS[0] <= epoch.year <= EPOCH_YEARS[1]:
        raise fault(f"EPOCH year {epoch.year} is outside {EPOCH_YEARS[0]}-{EPOCH_YEARS[1]}; "
                    f"element sets are dated from the first satellites on")
    norad_id = int(fields["NORAD_CAT_ID"])
    if not 0 < norad_id <= 999_999_999:
        raise fault(f"NORAD_CAT_ID must be a positive number, found {norad_id}")
    return ElementSet(
        name=name or str(norad_id), norad_id=norad_id,
        intl_designator=fields["OBJECT_ID"], epoch=epoch.replace(tzinfo=timezone.utc),
        line1=None, line2=None, source=source, line_no=record_no, omm=fields)


def _collect(records: Iterable[tuple[int, Mapping[str, Any]]], source: str, where: str,
             skip_bad: bool, on_warning: WarningHandler | None) -> list[ElementSet]:
    sets = []
    for record_no, record in records:
        try:
            sets.append(omm_to_element_set(record, source, record_no, where))
        except TleError as e:
            if not skip_bad:
                raise
            message = f"skipped a broken element set: {e}"
            if on_warning is not None:
                on_warning(message)
            else:
                warnings.warn(message, TleWarning, stacklevel=3)
    return sets


def parse_omm_json(text: str, source: str = "<string>", skip_bad: bool = False,
                   on_warning: Callable[[str], None] | None = None) -> list[ElementSet]:
    """CelesTrak ``FORMAT=json``: a list of flat objects (a single object is accepted)."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise TleFormatError(f"{source}:{e.lineno}: not valid JSON ({e.msg}, column {e.colno}); "
                             "expected a list of OMM records", source=source,
                             line_no=e.lineno) from None
    except RecursionError:
        # json nests one Python call per [ or {: OMM records are flat, so this is garbage.
        raise TleFormatError(f"{source}: JSON nested too deeply to be OMM records; expected "
                             'a list of flat OMM objects (like [{"OBJECT_NAME": ...}])',
                             source=source) from None
    if isinstance(data, dict):
        data = [data]
    if not isinstance(data, list) or not all(isinstance(item, dict) for item in data):
        raise TleFormatError(f"{source}: JSON should be a list of OMM objects "
                             '(like [{"OBJECT_NAME": ..., "EPOCH": ...}])', source=source)
    return _collect(enumerate(data, start=1), source, "record", skip_bad, on_warning)


def parse_omm_csv(text: str, source: str = "<string>", skip_bad: bool = False,
                  on_warning: Callable[[str], None] | None = None) -> list[ElementSet]:
    """CelesTrak ``FORMAT=csv``: a header row of OMM field names, one record per row."""
    from sgp4 import omm

    try:
        rows = list(omm.parse_csv(io.StringIO(text.lstrip("\ufeff"))))
    except csv.Error as e:
        raise TleFormatError(f"{source}: not valid CSV ({e}); expected a header row of OMM "
                             "field names and one record per line", source=source) from None
    # Row numbers count the header as line 1, as an editor shows them.
    return _collect(enumerate(rows, start=2), source, "line", skip_bad, on_warning)


def parse_omm_xml(text: str, source: str = "<string>", skip_bad: bool = False,
                  on_warning: Callable[[str], None] | None = None) -> list[ElementSet]:
    """CelesTrak ``FORMAT=xml``: an ``<ndm>`` of ``<omm>`` segments."""
    from sgp4 import omm

    try:
        segments = list(omm.parse_xml(io.StringIO(text.lstrip("\ufeff"))))
    except ParseError as e:
        line, column = e.position
        raise TleFormatError(f"{source}:{line}: not well-formed XML (column {column}); "
                             "expected an <ndm> of <omm> segments", source=source,
                             line_no=line) from None
    except (LookupError, ValueError) as e:
        # An unknown or mismatched encoding declaration in the XML prolog.
        raise TleFormatError(f"{source}: cannot decode the XML ({e}); expected UTF-8 OMM "
                             "XML", source=source) from None
    except AttributeError:
        # sgp4.omm.parse_xml dereferences metadata/data/meanElements without checks.
        raise TleFormatError(f"{source}: an OMM <segment> lacks <metadata>, <data>, "
                             "<meanElements> or <tleParameters>", source=source) from None
    return _collect(enumerate(segments, start=1), source, "segment", skip_bad, on_warning)
