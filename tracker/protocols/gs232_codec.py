"""GS-232 family commands (host to controller), both directions: the driver encodes them, the
emulator decodes them, so what one sends the other parses by construction.

A command line decodes to one small message (:data:`Command`); :func:`encode` gives its bytes
without the CR and :func:`decode_command` reads a received line back. Decoding is pure: the
limits that depend on the controller's state (360 or 450 mode, what the second field of ``W``
carries) are arguments, and whether a dialect has a command at all (``P45`` on a GS-232A, a
help page) is the controller's decision. The ``"azaz"`` dialect adds the GS-232B-AZ/AZ command
set 3 (``MB``, ``XB``, ``TB``, ``NB``, ``ZB``, ``P36B``/``P45B``) and the sync ``Y`` commands.
Long-form ``W``/``M`` table lines are :mod:`tracker.protocols.gs232_tables`'s; the replies
(``AZ=aaa  EL=eee``, ``+0aaa+0eee``, ``N``) are :mod:`tracker.protocols.gs232`'s. Byte-level
facts: ``docs/protocols.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from tracker.protocols.gs232_tables import (
    TableLine,
    decode_table_line,
    field3,
    format_table_line,
    table_line,
)

CR = b"\r"
FIELD_MAX = 999          # what three digits hold; decoded values were range-checked already

Dialect = Literal["gs232", "azaz"]
Axis = Literal["all", "az", "el"]
TurnDirection = Literal["cw", "ccw", "up", "down"]


# Messages: GS-232A/B and K3NG -----------------------------------------------------------------


@dataclass(frozen=True)
class Query:
    """``C`` (azimuth), ``C2`` (azimuth and elevation) or ``B`` (elevation)."""
    kind: Literal["C", "C2", "B"]


@dataclass(frozen=True)
class Stop:
    """``S`` (all), ``A`` (azimuth) or ``E`` (elevation)."""
    axis: Axis


@dataclass(frozen=True)
class Turn:
    """``R`` / ``L`` / ``U`` / ``D``: turn until stopped or at the end of travel."""
    direction: TurnDirection


@dataclass(frozen=True)
class Speed:
    """``X1`` (slowest) .. ``X4`` (fastest), azimuth."""
    step: int


@dataclass(frozen=True)
class SetMode450:
    """``P45`` (``enabled``) / ``P36`` (GS-232B)."""
    enabled: bool


@dataclass(frozen=True)
class ToggleCentre:
    """``Z``: north / south centre scale (GS-232B)."""


@dataclass(frozen=True)
class Calibrate:
    """``O`` / ``O2``: offset calibration, confirmed by a ``Y`` line."""
    command: Literal["O", "O2"]


@dataclass(frozen=True)
class FullScale:
    """``F`` / ``F2``: full-scale calibration, the reading streamed until a blank line."""
    command: Literal["F", "F2"]


@dataclass(frozen=True)
class Help:
    """``H`` / ``H2`` / ``H3``: ``page`` "" is the first."""
    page: Literal["", "2", "3"]


@dataclass(frozen=True)
class StartTable:
    """``T``: start stepping through the loaded table."""


@dataclass(frozen=True)
class TableStatus:
    """``N``: which point of how many."""


@dataclass(frozen=True)
class Goto:
    """Short form ``Maaa`` (``el`` None) or ``Waaa eee``."""
    az: int
    el: int | None = None


@dataclass(frozen=True)
class Table:
    """A long-form ``Msss aaa bbb ...`` / ``Wsss aaa eee ...`` line (point counts are the
    profile's business)."""
    line: TableLine


@dataclass(frozen=True)
class BadTable:
    """``M`` / ``W`` with no numbers or a malformed long form: the controller answers ``?>``
    and its table memory is cleared (manual)."""
    text: str


@dataclass(frozen=True)
class Invalid:
    """Anything else (a blank line, an unknown command, a short ``M``/``W`` out of range)."""
    text: str


# Messages: GS-232B-AZ/AZ (azimuth 2 on command set 3, and the sync commands) ------------------


@dataclass(frozen=True)
class Sync:
    """``Y`` (offset 0) / ``Ynnn``: azimuth 2 follows azimuth 1 + ``offset_deg`` (0..360)."""
    offset_deg: int


@dataclass(frozen=True)
class Unsync:
    """``Y999``: cancel the sync."""


@dataclass(frozen=True)
class GotoB:
    """``MBaaa``: azimuth 2 to 000-360."""
    az: int


@dataclass(frozen=True)
class TableB:
    """``MBsss aaa bbb ...``: the long-form M line of azimuth 2."""
    line: TableLine


@dataclass(frozen=True)
class BadTableB:
    """``MB`` with no numbers or a malformed long form: azimuth 2's table is cleared."""
    text: str


@dataclass(frozen=True)
class SpeedB:
    """``XB1`` .. ``XB4``: azimuth 2 speed."""
    step: int


@dataclass(frozen=True)
class ToggleCentreB:
    """``ZB``."""


@dataclass(frozen=True)
class SetMode450B:
    """``P45B`` / ``P36B``."""
    enabled: bool


@dataclass(frozen=True)
class StartTableB:
    """``TB``."""


@dataclass(frozen=True)
class TableStatusB:
    """``NB``."""


@dataclass(frozen=True)
class InvalidB:
    """A command-set-3 line the interface refuses (``O2B``, ``FB``, ``FB2``, a bad ``XB`` or
    short ``MB``): refused like :class:`Invalid`, but ignored like every set-3 command while
    the antennas are synced."""
    text: str


Command = (Query | Stop | Turn | Speed | SetMode450 | ToggleCentre | Calibrate | FullScale
           | Help | StartTable | TableStatus | Goto | Table | BadTable | Invalid
           | Sync | Unsync | GotoB | TableB | BadTableB | SpeedB | ToggleCentreB
           | SetMode450B | StartTableB | TableStatusB | InvalidB)

# Every command that is one fixed text, both ways.
_FIXED: dict[str, Command] = {
    "C": Query("C"), "C2": Query("C2"), "B": Query("B"),
    "S": Stop("all"), "A": Stop("az"), "E": Stop("el"),
    "R": Turn("cw"), "L": Turn("ccw"), "U": Turn("up"), "D": Turn("down"),
    **{f"X{n}": Speed(n) for n in range(1, 5)},
    "P36": SetMode450(False), "P45": SetMode450(True), "Z": ToggleCentre(),
    "O": Calibrate("O"), "O2": Calibrate("O2"), "F": FullScale("F"), "F2": FullScale("F2"),
    "H": Help(""), "H2": Help("2"), "H3": Help("3"),
    "T": StartTable(), "N": TableStatus(),
}
_FIXED_AZAZ: dict[str, Command] = {
    "Y": Sync(0), "Y999": Unsync(),
    **{f"XB{n}": SpeedB(n) for n in range(1, 5)},
    "ZB": ToggleCentreB(), "P36B": SetMode450B(False), "P45B": SetMode450B(True),
    "TB": StartTableB(), "NB": TableStatusB(),
    "O2B": InvalidB("O2B"), "FB": InvalidB("FB"), "FB2": InvalidB("FB2"),
}
_TEXT: dict[Command, str] = {msg: text for text, msg in (_FIXED | _FIXED_AZAZ).items()
                             if not isinstance(msg, InvalidB)}


# Encoding -------------------------------------------------------------------------------------


def _digits3(value: int) -> str:
    if not 0 <= value <= FIELD_MAX:
        raise ValueError(f"{value!r} does not fit a 3-digit GS-232 field")
    return f"{value:03d}"


def encode(msg: Command) -> bytes:
    """The command line for ``msg``, without the CR."""
    if isinstance(msg, (Goto, GotoB, Table, TableB, Sync)):
        return _encode_with_values(msg).encode("ascii")
    text = _TEXT.get(msg)
    if text is None:
        raise ValueError(f"{msg!r} is not a command a host sends")
    return text.encode("ascii")


def _encode_with_values(msg: Goto | GotoB | Table | TableB | Sync) -> str:
    if isinstance(msg, Goto):
        if msg.el is None:
            return "M" + _digits3(msg.az)
        return f"W{_digits3(msg.az)} {_digits3(msg.el)}"
    if isinstance(msg, GotoB):
        return "MB" + _digits3(msg.az)
    if isinstance(msg, Table):
        return format_table_line(msg.line)
    if isinstance(msg, TableB):
        if msg.line.kind != "M":
            raise ValueError("an azimuth-2 table is a long-form M line")
        return "MB" + format_table_line(msg.line)[1:]
    return "Y" if msg.offset_deg == 0 else "Y" + _digits3(msg.offset_deg)


def goto_message(az_deg: float, el_deg: float | None = None, *, az_max_deg: float = 450.0,
                 el_max_deg: float = 180.0) -> Goto:
    """The :class:`Goto` for a wire position; out of range raises
    :class:`tracker.errors.LimitError` (nothing is sent)."""
    az = field3(az_deg, "azimuth", 0, az_max_deg)
    return Goto(az, None if el_deg is None else field3(el_deg, "elevation", 0, el_max_deg))


def encode_goto(az_deg: float, el_deg: float | None = None, *, az_max_deg: float = 450.0,
                el_max_deg: float = 180.0) -> bytes:
    """``Waaa eee\\r`` (az/el) or ``Maaa\\r`` (azimuth only)."""
    return encode(goto_message(az_deg, el_deg, az_max_deg=az_max_deg,
                               el_max_deg=el_max_deg)) + CR


def table_message(interval_s: float, points: Sequence, *, az_max_deg: float = 450.0,
                  el_max_deg: float = 180.0) -> Table:
    """The long-form :class:`Table` of a list of azimuths (an ``M`` line) or of (az, el)
    pairs (a ``W`` line); out of range raises :class:`tracker.errors.LimitError`."""
    if len(points) and not isinstance(points[0], (int, float)):
        pairs = [(a, e) for a, e in points]
        az, el = [a for a, _ in pairs], [e for _, e in pairs]
        return Table(table_line("W", interval_s, az, el, az_max_deg=az_max_deg,
                                el_max_deg=el_max_deg))
    return Table(table_line("M", interval_s, points, az_max_deg=az_max_deg))


def encode_table(interval_s: float, points: Sequence, *, az_max_deg: float = 450.0,
                 el_max_deg: float = 180.0) -> bytes:
    """Long form: ``Msss aaa bbb ...\\r`` for a list of azimuths, ``Wsss aaa eee ...\\r`` for a
    list of (az, el) pairs."""
    return encode(table_message(interval_s, points, az_max_deg=az_max_deg,
                                el_max_deg=el_max_deg)) + CR


# Decoding -------------------------------------------------------------------------------------


def command_text(raw: bytes) -> str | None:
    """A received line as the controller reads it (ASCII, blanks around it dropped, any case),
    or None when it is not ASCII."""
    try:
        return raw.decode("ascii").strip().upper()
    except UnicodeDecodeError:
        return None


def _short_number(text: str, lo: int, hi: int) -> int | None:
    """A short-form field: 1-3 digits within ``lo..hi``, else None."""
    if not (text.isdigit() and len(text) <= 3):
        return None
    value = int(text)
    return value if lo <= value <= hi else None


def decode_command(line: bytes | str, *, dialect: Dialect = "gs232",
                   az_max_deg: int = 450, el_max_deg: int = 180) -> Command:
    """One received line (without the CR) → its message.

    ``az_max_deg`` bounds azimuths (360 or 450, the controller's mode) and ``el_max_deg`` the
    second field of ``W`` (180, or 360 where it carries azimuth 2); a value outside them makes
    the line :class:`Invalid` (short form) or :class:`BadTable` (long form).
    """
    text = command_text(line) if isinstance(line, bytes) else line.strip().upper()
    if text is None:
        return Invalid(line.decode("ascii", "replace") if isinstance(line, bytes) else line)
    if dialect == "azaz":
        msg = _decode_azaz(text)
        if msg is not None:
            return msg
    fixed = _FIXED.get(text)
    if fixed is not None:
        return fixed
    if text[:1] in ("M", "W"):
        return _decode_set(text, az_max_deg, el_max_deg)
    return Invalid(text)


def _decode_set(text: str, az_max_deg: int, el_max_deg: int) -> Command:
    """``Maaa`` / ``Waaa eee`` (short form) or a long-form table line."""
    head, args = text[0], text[1:].split()
    if not args:
        return BadTable(text)
    if (head == "M" and len(args) == 1) or (head == "W" and len(args) == 2):
        az = _short_number(args[0], 0, az_max_deg)
        el = _short_number(args[1], 0, el_max_deg) if head == "W" else None
        if az is None or (head == "W" and el is None):
            return Invalid(text)
        return Goto(az, el)
    try:
        return Table(decode_table_line(text, strict=False, az_max_deg=az_max_deg,
                                       el_max_deg=el_max_deg))
    except ValueError:
        return BadTable(text)


def _decode_azaz(text: str) -> Command | None:
    """The AZ/AZ additions, or None for a line the GS-232B part decodes."""
    fixed = _FIXED_AZAZ.get(text)
    if fixed is not None:
        return fixed
    if text[:1] == "Y" and text[1:].isdigit() and len(text) == 4:
        n = int(text[1:])
        return Sync(n) if n <= 360 else Invalid(text)
    if text.startswith("XB"):
        return InvalidB(text)
    if text.startswith("MB"):
        return _decode_mb(text)
    return None


def _decode_mb(text: str) -> Command:
    args = text[2:].split()
    if len(args) == 1:
        az = _short_number(args[0], 0, 360)
        return InvalidB(text) if az is None or len(args[0]) != 3 else GotoB(az)
    try:   # MBsss aaa ... is the long-form M line of antenna 2
        return TableB(decode_table_line("M" + " ".join(args), strict=False, az_max_deg=360))
    except ValueError:
        return BadTableB(text)
