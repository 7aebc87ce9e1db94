"""Element sets: the TLE/3LE parser and the format-sniffing loader (``ElementSet`` itself is
in :mod:`tle.element_set`, shared with the OMM parser, and re-exported here).

``parse_tle_text`` reads 2-line and 3-line sets (LF or CRLF, blank lines, trailing blanks, a
leading ``0 `` on name lines), checks the column layout, both checksums, Alpha-5 catalogue
numbers and that lines 1 and 2 name the same object. A broken set raises one
:class:`~tle.errors.TleFormatError` naming ``source:line``; ``skip_bad=True`` turns each broken
set into one warning instead. ``load_file``/``parse_text`` also accept OMM (JSON, CSV, XML).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator
from datetime import datetime, timedelta, timezone
from pathlib import Path

from tle import omm
from tle.alpha5 import alpha5_to_int
from tle.checksum import compute_checksum
from tle.element_set import ElementSet, WarningHandler
from tle.errors import TleError, TleFormatError, TleWarning
from tle.layout import TEMPLATES, TLE_LINE_LENGTH, layout_fault
from tle.omm import MAX_MEAN_MOTION_REV_DAY

_INTL_RE = re.compile(r"^(\d\d)(\d{3})([A-Z]{1,3})$")


def format_intl_designator(raw: str) -> str:
    """TLE columns 10-17 ("98067A  ") in CelesTrak's OBJECT_ID form ("1998-067A")."""
    text = raw.strip()
    match = _INTL_RE.match(text)
    if not match:
        return text
    yy, launch, piece = match.groups()
    year = 1900 + int(yy) if int(yy) >= 57 else 2000 + int(yy)
    return f"{year}-{launch}{piece}"


def tle_epoch(line1: str) -> datetime:
    """Epoch from line 1 columns 19-32 (two-digit year: 57-99 → 19xx, else 20xx)."""
    yy = int(line1[18:20])
    day = float(line1[20:32])
    year = 1900 + yy if yy >= 57 else 2000 + yy
    return datetime(year, 1, 1, tzinfo=timezone.utc) + timedelta(days=day - 1.0)


def _fault(source: str, line_no: int, name: str, which: int | None, what: str,
           line: str | None, layout: bool = True) -> TleFormatError:
    who = f"{name!r} " if name else ""
    part = f"line {which}: " if which else ""
    message = f"{source}:{line_no}: {who}{part}{what}"
    if layout and which:
        message += f"; line {which} layout: {TEMPLATES[which]}"
    return TleFormatError(message, source=source, line_no=line_no, line=line)


def _check_line(line: str, which: int, line_no: int, source: str, name: str) -> None:
    if len(line) != TLE_LINE_LENGTH:
        hint = " (truncated?)" if len(line) < TLE_LINE_LENGTH else ""
        raise _fault(source, line_no, name, which,
                     f"{len(line)} characters long, expected {TLE_LINE_LENGTH}{hint}", line)
    fault = layout_fault(line, which)
    if fault:
        raise _fault(source, line_no, name, which, fault, line)
    expected = compute_checksum(line)
    found = int(line[68])
    if expected != found:
        raise _fault(source, line_no, name, which,
                     f"checksum expected {expected}, found {found} (column 69 is the sum of the "
                     "digits in columns 1-68, each '-' counting 1, modulo 10)", line,
                     layout=False)


def _build(name: str, line1: str, line2: str, l1_no: int, l2_no: int,
           source: str) -> ElementSet:
    _check_line(line1, 1, l1_no, source, name)
    _check_line(line2, 2, l2_no, source, name)
    try:
        norad_id = alpha5_to_int(line1[2:7])
    except ValueError as e:
        raise _fault(source, l1_no, name, 1, f"columns 3-7: {e}", line1) from None
    if line2[2:7] != line1[2:7]:
        raise _fault(source, l2_no, name, 2,
                     f"catalogue number {line2[2:7].strip()!r} does not match line 1's "
                     f"{line1[2:7].strip()!r} (columns 3-7 of both lines must agree)", line2,
                     layout=False)
    try:
        day = float(line1[20:32])
    except ValueError:
        raise _fault(source, l1_no, name, 1,
                     f"epoch day of year {line1[20:32]!r} is not a number (columns 21-32, "
                     "like 234.50538338)", line1) from None
    if not 1.0 <= day < 367.0:
        raise _fault(source, l1_no, name, 1,
                     f"epoch day of year {day} is outside 1..366 (columns 21-32)", line1)
    try:
        mean_motion = float(line2[52:63])
    except ValueError:
        mean_motion = math.nan
    if not 0.0 < mean_motion <= MAX_MEAN_MOTION_REV_DAY:   # SGP4 divides by it
        raise _fault(source, l2_no, name, 2,
                     f"mean motion {line2[52:63].strip()!r} must be above 0 and at most "
                     f"{MAX_MEAN_MOTION_REV_DAY:g} rev/day (columns 53-63)", line2)
    return ElementSet(
        name=name or str(norad_id), norad_id=norad_id,
        intl_designator=format_intl_designator(line1[9:17]), epoch=tle_epoch(line1),
        line1=line1, line2=line2, source=source, line_no=l1_no)


def _report(error: TleError, on_warning: WarningHandler | None) -> None:
    message = f"skipped a broken element set: {error}"
    if on_warning is not None:
        on_warning(message)
    else:
        warnings.warn(message, TleWarning, stacklevel=4)


def _clean_lines(text: str) -> Iterator[tuple[int, str]]:
    for line_no, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip()
        if line:
            yield line_no, line.lstrip("\ufeff")


def _is_line(line: str, which: int) -> bool:
    return line.startswith(f"{which} ") or (len(line) > 60 and line[0] == str(which))


def parse_tle_text(text: str, source: str = "<string>", skip_bad: bool = False,
                   on_warning: WarningHandler | None = None) -> list[ElementSet]:
    """Parse 2-line and 3-line element sets from ``text``.

    A broken set raises :class:`TleFormatError` (``source:line``, the fault, the layout). With
    ``skip_bad=True`` each broken set is reported once through ``on_warning`` (or
    ``warnings.warn`` with :class:`TleWarning`) and skipped.
    """
    lines = list(_clean_lines(text))
    sets: list[ElementSet] = []
    i = 0
    while i < len(lines):
        start = i
        name = ""
        try:
            line_no, line = lines[i]
            if _is_line(line, 2):
                raise _fault(source, line_no, "", 2, "line 2 without a line 1 before it", line,
                             layout=False)
            if not _is_line(line, 1):
                name = line[2:].strip() if line.startswith("0 ") else line.strip()
                i += 1
                if i >= len(lines) or not _is_line(lines[i][1], 1):
                    raise _fault(source, line_no, "", None,
                                 f"name line {name!r} is not followed by a line 1 (each set is "
                                 "an optional name line, then line 1, then line 2)", line)
            l1_no, line1 = lines[i]
            i += 1
            if i >= len(lines) or not _is_line(lines[i][1], 2):
                raise _fault(source, l1_no, name, 1, "is not followed by a line 2", line1,
                             layout=False)
            l2_no, line2 = lines[i]
            i += 1
            sets.append(_build(name, line1, line2, l1_no, l2_no, source))
        except TleFormatError as e:
            if not skip_bad:
                raise
            _report(e, on_warning)
            # Resync: continue after the set's line 2 if we reached it, else one line on.
            i = max(i, start + 1)
    return sets


def sniff_format(text: str) -> str:
    """"tle", "json", "csv", "xml" or "html" from the first characters of ``text``."""
    head = text.lstrip("\ufeff \t\r\n")[:512]
    lower = head.lower()
    if lower.startswith(("<!doctype html", "<html")) or "<html" in lower[:200]:
        return "html"
    if head.startswith("<"):
        return "xml"
    if head.startswith(("[", "{")):
        return "json"
    first = head.splitlines()[0] if head else ""
    if "," in first and ("OBJECT_NAME" in first or "NORAD_CAT_ID" in first):
        return "csv"
    return "tle"


def parse_text(text: str, source: str = "<string>", skip_bad: bool = False,
               on_warning: WarningHandler | None = None) -> list[ElementSet]:
    """Parse TLE/3LE or OMM (JSON, CSV, XML) text, sniffing which it is."""
    kind = sniff_format(text)
    if kind == "html":
        raise TleFormatError(
            f"{source}: this is an HTML page, not element sets (an error page or a wrong URL?)",
            source=source)
    if kind == "tle":
        return parse_tle_text(text, source, skip_bad, on_warning)
    parser = {"json": omm.parse_omm_json, "csv": omm.parse_omm_csv, "xml": omm.parse_omm_xml}
    return parser[kind](text, source, skip_bad, on_warning)


def load_file(path: str | Path, skip_bad: bool = False,
              on_warning: WarningHandler | None = None) -> list[ElementSet]:
    """Read a TLE/3LE/OMM file (format sniffed from its content)."""
    from tle.textfile import ELEMENT_FILE_MAX_BYTES, read_text_file

    path = Path(path)
    text = read_text_file(path, "element file", TleFormatError, ELEMENT_FILE_MAX_BYTES,
                          "expected TLE/3LE or OMM JSON/CSV/XML")
    return parse_text(text, str(path), skip_bad, on_warning)
