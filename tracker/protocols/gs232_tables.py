"""GS-232 long-form step-table lines (``Wsss aaa eee ...`` / ``Msss aaa ...``): the one codec.

Every W/M table line is encoded and decoded here, whoever sends or reads it: the driver
(:meth:`tracker.protocols.gs232.Gs232Driver.upload_table`, the AZ/AZ driver), the step-table
compiler and plan files (:mod:`tracker.steptable`) and the emulated controllers
(:mod:`tracker.emulator.gs232_controller`). The facts are in ``docs/protocols.md``, "Step
tables". Pure text in and out: no port, no profile; point counts and line lengths are each
controller's (or profile's) business, value ranges and the format are checked here.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import NamedTuple

from tracker.errors import LimitError

KINDS = ("W", "M")
INTERVAL_MIN_S = 1
INTERVAL_MAX_S = 999
AZ_MAX_DEG = 450
EL_MAX_DEG = 180


def field3(value: float, what: str, lo: float, hi: float) -> int:
    """``value`` rounded half to even (like Hamlib's rint) and range-checked: the number a
    3-digit GS-232 field carries. Raises :class:`LimitError` (nothing is sent)."""
    try:
        n = round(float(value))
    except (TypeError, ValueError, OverflowError) as e:
        raise LimitError(f"{what} {value!r} is not a number") from e
    if not (lo <= n <= hi):
        raise LimitError(f"{what} {value!r} deg is outside the controller range "
                         f"{lo:g}..{hi:g} deg; nothing was sent")
    return n


class TableLine(NamedTuple):
    """One decoded long-form line: ``el`` is None for an M (azimuth-only) line."""

    kind: str
    interval_s: int
    az: list[int]
    el: list[int] | None


def table_line(kind: str, interval_s: float, az: Collection[float],
               el: Collection[float] | None = None, *, az_max_deg: float = AZ_MAX_DEG,
               el_max_deg: float = EL_MAX_DEG) -> TableLine:
    """The checked :class:`TableLine` of a ``W`` table (``kind`` "W", one elevation per
    azimuth) or an ``M`` table (``kind`` "M"): every number is rounded half to even and
    range-checked (:class:`LimitError`, nothing sent)."""
    if kind not in KINDS:
        raise ValueError(f"table kind {kind!r} is invalid; use W (az/el) or M (azimuth)")
    if isinstance(interval_s, float) and not interval_s.is_integer():
        raise LimitError(f"table interval {interval_s!r} s must be a whole number of seconds")
    interval = field3(interval_s, "table interval", INTERVAL_MIN_S, INTERVAL_MAX_S)
    if not len(az):
        raise LimitError("a step table needs at least one point")
    if kind == "W":
        if el is None:
            raise ValueError("a W table line needs one elevation per azimuth")
        az_out, el_out = [], []
        for a, e in zip(az, el, strict=True):
            az_out.append(field3(a, "azimuth", 0, az_max_deg))
            el_out.append(field3(e, "elevation", 0, el_max_deg))
        return TableLine(kind, interval, az_out, el_out)
    return TableLine(kind, interval, [field3(a, "azimuth", 0, az_max_deg) for a in az], None)


def format_table_line(line: TableLine) -> str:
    """``Wsss aaa eee aaa eee ...`` / ``Msss aaa bbb ...`` without the CR, every number as
    three digits (the values are :func:`table_line`'s or :func:`decode_table_line`'s)."""
    values = (line.az if line.el is None
              else [v for pair in zip(line.az, line.el, strict=True) for v in pair])
    return line.kind + " ".join(f"{v:03d}" for v in (line.interval_s, *values))


def encode_table_line(kind: str, interval_s: float, az: Collection[float],
                      el: Collection[float] | None = None, *, az_max_deg: float = AZ_MAX_DEG,
                      el_max_deg: float = EL_MAX_DEG) -> str:
    """``Wsss aaa eee aaa eee ...`` (``kind`` "W", one elevation per azimuth) or
    ``Msss aaa bbb ...`` (``kind`` "M"), without the CR. Every number is range-checked
    (:class:`LimitError`, nothing sent) and written as three digits."""
    return format_table_line(table_line(kind, interval_s, az, el, az_max_deg=az_max_deg,
                                        el_max_deg=el_max_deg))


def _number(text: str, strict: bool) -> int:
    if not text.isdigit() or (len(text) != 3 if strict else len(text) > 3):
        raise ValueError(text)
    return int(text)


def decode_table_line(line: str | bytes, *, strict: bool = True,
                      az_max_deg: int | None = None,
                      el_max_deg: int = EL_MAX_DEG) -> TableLine:
    """A long-form W/M line (without CR) → :class:`TableLine`; ``ValueError`` if malformed.

    ``strict``: exactly the encoder's format (three digits per number, one space between),
    as a plan file must hold; otherwise what a controller takes (1-3 digits, any blanks).
    With ``az_max_deg`` the values are range-checked too (interval 001-999, azimuth
    0..``az_max_deg``, elevation 0..``el_max_deg``); without, the caller checks them (a plan
    file's tables are checked against their profile, with its name in the message).
    A W line needs whole (az, el) pairs, and every line at least one point.
    """
    if isinstance(line, bytes):
        try:
            line = line.decode("ascii")
        except UnicodeDecodeError:
            raise ValueError(line) from None
    kind = line[:1].upper()
    fields = line[1:].split(" ") if strict else line[1:].split()
    if kind not in KINDS or len(fields) < 2:
        raise ValueError(line)
    interval, *values = (_number(f, strict) for f in fields)
    if kind == "W" and len(values) % 2:
        raise ValueError(line)
    az = values[0::2] if kind == "W" else values
    el = values[1::2] if kind == "W" else None
    if az_max_deg is not None and not (
            INTERVAL_MIN_S <= interval <= INTERVAL_MAX_S
            and all(0 <= a <= az_max_deg for a in az)
            and all(0 <= e <= el_max_deg for e in el or ())):
        raise ValueError(line)
    return TableLine(kind, interval, az, el)
