"""Easycomm II / III codec, both directions: what the driver sends and parses, what the
emulator decodes and answers (docs/protocols.md, "Easycomm").

A command is a two-letter identifier with its value glued on (``AZ120.0``); commands are
separated by spaces, CR or LF, and a bare identifier asks for the value (``AZ`` → ``AZ120.0``).
The bytes follow Hamlib's easycomm backend: set ``AZ%.1f EL%.1f\\n``, query ``AZ EL \\n``,
stop ``SA SE \\n``; the position reply is one line ``AZaaa.a ELeee.e`` ended by LF.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal

from tracker.errors import LimitError, ProtocolError

EOL = b"\n"
QUERY = b"AZ EL \n"
STOP = b"SA SE \n"
STOP_AXIS = {"az": b"SA \n", "el": b"SE \n"}
MOVE = {"ccw": b"ML\n", "cw": b"MR\n", "up": b"MU\n", "down": b"MD\n"}
AZ_MAX_DEG = 360.0       # Hamlib's easycomm caps: azimuth 0-360, elevation 0-180
EL_MAX_DEG = 180.0
_NUMBER = rb"[-+]?(?:\d+(?:\.\d*)?|\.\d+)"
_POSITION_RE = re.compile(rb"AZ\s*(" + _NUMBER + rb")\s+EL\s*(" + _NUMBER + rb")")
_TOKEN_RE = re.compile(rb"^([A-Z]{2})(.*)$")


def _angle(value: float, what: str, max_deg: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as e:
        raise LimitError(f"{what} {value!r} is not a number") from e
    if math.isnan(v) or not 0.0 <= v <= max_deg:
        raise LimitError(f"{what} {value!r} deg is outside 0..{max_deg:g} deg; nothing was sent")
    return v


# Host to controller ---------------------------------------------------------------------------


def encode_goto(az_deg: float, el_deg: float | None = None, *, az_max_deg: float = AZ_MAX_DEG,
                el_max_deg: float = EL_MAX_DEG) -> bytes:
    """``AZaaa.a ELeee.e\\n`` (one decimal, as Hamlib's ``%.1f``); ``AZaaa.a\\n`` without an
    elevation. Out of range or NaN raises :class:`LimitError` before anything is encoded."""
    az = _angle(az_deg, "azimuth", az_max_deg)
    if el_deg is None:
        return b"AZ%.1f\n" % az
    el = _angle(el_deg, "elevation", el_max_deg)
    return b"AZ%.1f EL%.1f\n" % (az, el)


def parse_position(line: bytes) -> tuple[float, float]:
    """``(az, el)`` from a reply holding ``AZaaa.a ELeee.e`` (any spacing, Hamlib's
    ``sscanf("AZ%f EL%f")``); anything else raises :class:`ProtocolError`."""
    m = _POSITION_RE.search(line)
    if m is None:
        raise ProtocolError("Easycomm position reply is not 'AZaaa.a ELeee.e'", line)
    return float(m.group(1)), float(m.group(2))


# Controller side ------------------------------------------------------------------------------

Axis = Literal["az", "el"]
MoveDirection = Literal["ccw", "cw", "up", "down"]


@dataclass(frozen=True)
class SetAxis:
    axis: Axis
    deg: float


@dataclass(frozen=True)
class Query:
    axis: Axis


@dataclass(frozen=True)
class StopAxis:
    axis: Axis


@dataclass(frozen=True)
class Move:
    """``ML``/``MR``/``MU``/``MD``, or Easycomm III's ``VL``/``VR``/``VU``/``VD`` with a rate
    in millidegrees per second (``rate_mdeg_s`` None: the controller's own rate)."""
    direction: MoveDirection
    rate_mdeg_s: float | None = None


@dataclass(frozen=True)
class Version:
    pass


@dataclass(frozen=True)
class Unknown:
    token: bytes


Command = SetAxis | Query | StopAxis | Move | Version | Unknown

_AXIS: dict[bytes, Axis] = {b"AZ": "az", b"EL": "el"}
_STOPS: dict[bytes, Axis] = {b"SA": "az", b"SE": "el"}
_MOVES: dict[bytes, MoveDirection] = {b"ML": "ccw", b"MR": "cw", b"MU": "up", b"MD": "down"}
_RATES: dict[bytes, MoveDirection] = {b"VL": "ccw", b"VR": "cw", b"VU": "up", b"VD": "down"}


def _number(text: bytes) -> float | None:
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def decode_token(token: bytes) -> Command:
    """One command: ``AZ120.0``, ``EL``, ``SA``, ``MU``, ``VL2000``, ``VE`` ..."""
    m = _TOKEN_RE.match(token.upper())
    if m is None:
        return Unknown(token)
    ident, rest = m.group(1), m.group(2)
    value = _number(rest) if rest else None
    if ident in _AXIS:
        if not rest:
            return Query(_AXIS[ident])
        return SetAxis(_AXIS[ident], value) if value is not None else Unknown(token)
    if not rest and ident in _STOPS:
        return StopAxis(_STOPS[ident])
    if not rest and ident in _MOVES:
        return Move(_MOVES[ident])
    if ident in _RATES and value is not None:
        return Move(_RATES[ident], value)
    if ident == b"VE" and not rest:
        return Version()
    return Unknown(token)


def decode_line(line: bytes) -> list[Command]:
    """Every command of one line (space-separated, as Easycomm II allows)."""
    return [decode_token(t) for t in line.split()]


def format_value(axis: Axis, deg: float) -> bytes:
    """``AZaaa.a`` / ``ELeee.e``: a query's answer, echoing the identifier."""
    return b"%s%.1f" % (b"AZ" if axis == "az" else b"EL", deg)


def format_reply(fields: list[bytes]) -> bytes:
    """The answers to one line's queries on one line (``AZ120.0 EL30.0\\n``), the form Hamlib
    and the SatNOGS firmware exchange; nothing when the line asked nothing."""
    return b" ".join(fields) + EOL if fields else b""
