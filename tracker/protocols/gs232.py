"""GS-232 family (Yaesu GS-23/GS-232/GS-232A/GS-232B, K3NG): dialect profiles, replies, driver.

The codec is shared by the driver and the emulator, so what one sends the other understands
by construction: the commands both ways are :mod:`tracker.protocols.gs232_codec`'s, the
replies both ways (``parse_*`` / ``format_*``) are here. Byte-level facts and their sources
are in ``docs/protocols.md``; the dialects are :data:`PROFILES` below.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

from tracker.clock import Clock
from tracker.errors import (
    ConfigError,
    LimitError,
    ProtocolError,
    RotatorTimeout,
)
from tracker.protocols.base import Capabilities, Direction
from tracker.protocols.framing import LineFramer
from tracker.protocols.gs232_codec import (
    CR,
    Help,
    Query,
    SetMode450,
    Speed,
    StartTable,
    Stop,
    TableStatus,
    ToggleCentre,
    Turn,
    encode,
    encode_table,
    goto_message,
)
from tracker.protocols.link import ByteLink, LinkDriver, driver_on_port
from tracker.transport import Port

ERROR_REPLY = b"?>"

# Profiles -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Gs232Profile:
    """One dialect: what the controller sends (emulator) and what the driver expects.

    ``family`` "a" answers ``+0aaa+0eee``; "b" answers ``AZ=aaa{c2_separator}EL=eee``.
    ``set_ack`` is what a set/move command gets back (real GS-232B: nothing; manual: CR;
    K3NG: CR LF). ``n_style`` "plus" answers N with ``+nnnn+mmmm``, "count" with the bare
    number of points (K3NG). ``end_behaviour`` is what stepping does after the last point.
    """

    name: str
    family: Literal["a", "b"]
    description: str = ""
    c2_separator: bytes = b"  "
    reply_eol: bytes = b"\r\n"
    set_ack: bytes = b""
    k3ng_messages: bool = False
    max_table_points: int = 3800
    max_table_pairs: int = 1900
    min_table_points: int = 2
    max_line_chars: int = 65536
    table_period_extra_s: float = 0.0
    end_behaviour: Literal["stay", "clear"] = "stay"
    n_style: Literal["plus", "count"] = "plus"
    rtscts: bool = False
    pace_cmd_s: float = 0.0
    b_commands: bool = False
    help_pages: tuple[str, ...] = ("", "2")
    baudrate: int = 9600
    lf_is_command: bool = False
    # The largest value the second (EL) field can carry: AZ/AZ boxes put azimuth 2 there.
    second_field_max_deg: int = 180

    def with_(self, **changes: Any) -> Gs232Profile:
        return replace(self, **changes)

    def capabilities(self, has_elevation: bool = True, az_max_deg: float = 450.0,
                     el_max_deg: float = 180.0) -> Capabilities:
        return Capabilities(
            has_elevation=has_elevation, has_step_tables=True,
            max_table_points=self.max_table_points,
            max_table_pairs=self.max_table_pairs if has_elevation else 0,
            max_line_chars=self.max_line_chars,
            table_period_extra_s=self.table_period_extra_s,
            has_450_mode=self.b_commands, has_centre_toggle=self.b_commands,
            az_max_deg=az_max_deg, el_max_deg=el_max_deg)


PROFILES: dict[str, Gs232Profile] = {
    "gs232a": Gs232Profile(
        name="gs232a", family="a", set_ack=CR, pace_cmd_s=0.05,
        description="Yaesu GS-232A (and GS-23/GS-232 Kenpro): +0aaa+0eee, CR acks, no "
                    "handshake"),
    "gs23": Gs232Profile(
        name="gs23", family="a", set_ack=CR, pace_cmd_s=0.05,
        description="Kenpro GS-23/GS-232 (V1.2): as gs232a, the original help screens"),
    "gs232b": Gs232Profile(
        name="gs232b", family="b", c2_separator=b"  ", set_ack=b"", rtscts=True,
        b_commands=True, help_pages=("", "2", "3"),
        description="Yaesu GS-232B as real units behave: AZ=aaa  EL=eee, silent set "
                    "commands, ?> for blank/invalid lines, CTS flow control"),
    "gs232b-manual": Gs232Profile(
        name="gs232b-manual", family="b", c2_separator=b" ", set_ack=CR, rtscts=True,
        b_commands=True, help_pages=("", "2", "3"),
        description="GS-232B exactly as the manual reads: AZ=aaa EL=eee, CR after every "
                    "command"),
    "k3ng": Gs232Profile(
        name="k3ng", family="b", c2_separator=b"", set_ack=b"\r\n", k3ng_messages=True,
        max_table_points=20, max_table_pairs=20, min_table_points=1, max_line_chars=50,
        table_period_extra_s=1.0, end_behaviour="clear", n_style="count", pace_cmd_s=0.05,
        b_commands=True, help_pages=(),
        description="K3NG Arduino rotator controller in GS-232B emulation: AZ=aaaEL=eee, "
                    "CR LF after every command, 20-point timed buffer, 50-char lines"),
}


def get_profile(name: str | Gs232Profile) -> Gs232Profile:
    if isinstance(name, Gs232Profile):
        return name
    p = PROFILES.get(str(name).lower())
    if p is None:
        raise ConfigError(f"unknown GS-232 profile {name!r}; known: {', '.join(PROFILES)}")
    return p


# Codec: replies --------------------------------------------------------------------------------

# Fields are zero-padded: 3 digits (4 on ERC-style azimuths), or a short negative such as
# SPID's `-00`. Replies carry no checksum, so a field with a digit dropped or doubled by line
# noise is refused here by its width or range rather than read as a wrong angle.
_FIELD = rb"([+-]?\d{2,4})"
_AZEL_RE = re.compile(rb"^AZ=\s*" + _FIELD + rb"\s*(?:EL=\s*" + _FIELD + rb")?$")
_EL_RE = re.compile(rb"^EL=\s*" + _FIELD + rb"$")
_PLUS_RE = re.compile(rb"^([+-]\d{4,5})(?:([+-]\d{4,5}))?$")
_AZ_MAX_DEG = 450
_EL_MAX_DEG = 180
_N_RE = re.compile(rb"^[+=](\d{1,4})[+=](\d{1,4})$")


def is_error_reply(line: bytes) -> bool:
    """``?>`` (real units), ``? >`` (some clones) or a lone ``>``."""
    return line.strip().replace(b" ", b"") in (b"?>", b">")


def parse_position(line: bytes, el_max_deg: int = _EL_MAX_DEG) -> tuple[float, float | None]:
    """Parse a C/C2 reply: ``AZ=aaa  EL=eee`` (any spacing, negatives, 4-digit az),
    ``AZ=aaa``, ``+0aaa+0eee`` or ``+0aaa``; raises :class:`ProtocolError`. ``el_max_deg``
    bounds the second field (450 where it carries a second azimuth)."""
    s = line.strip()
    m = _AZEL_RE.match(s) or _PLUS_RE.match(s)
    if m:
        az = _angle(m.group(1), _AZ_MAX_DEG)
        el = None if m.group(2) is None else _angle(m.group(2), el_max_deg)
        if az is not None and (m.group(2) is None or el is not None):
            return az, el
    raise ProtocolError("not a GS-232 position reply (expected AZ=aaa EL=eee or +0aaa+0eee "
                        "with 3-digit fields in range)", line)


def parse_elevation(line: bytes, el_max_deg: int = _EL_MAX_DEG) -> float:
    s = line.strip()
    m = _EL_RE.match(s) or _PLUS_RE.match(s)
    if m and m.lastindex == 1:
        el = _angle(m.group(1), el_max_deg)
        if el is not None:
            return el
    raise ProtocolError("not a GS-232 elevation reply (expected EL=eee or +0eee)", line)


def _angle(field: bytes, max_deg: int) -> float | None:
    """A reply field as degrees, or None if no controller could have sent it."""
    digits = field.lstrip(b"+-")
    negative = field.startswith(b"-")
    if len(digits) < 3 and not negative:
        return None
    value = int(digits)
    if value > max_deg:
        return None
    return float(-value if negative else value)


def parse_table_status(line: bytes) -> tuple[int | None, int]:
    """N reply → (current point 1-based, total). ``+nnnn+mmmm`` per the manuals, ``=nnnn=mmmm``
    (the GS-232B manual's OCR, copied by clones); K3NG answers the total only → (None, total)."""
    s = line.strip()
    m = _N_RE.match(s)
    if m:
        return int(m.group(1)), int(m.group(2))
    if s.isdigit():
        return None, int(s)
    raise ProtocolError("not a GS-232 N reply (expected +nnnn+mmmm)", line)


def _signed3(v: int) -> bytes:
    return (b"-" if v < 0 else b"") + b"%03d" % abs(v)


def format_position(profile: Gs232Profile, cmd: str, az: int, el: int) -> bytes:
    """The controller's reply line (without EOL) to C, C2 or B."""
    if profile.family == "a":
        def f(v: int) -> bytes:
            return (b"-0" if v < 0 else b"+0") + b"%03d" % abs(v)
        return {"C": f(az), "B": f(el), "C2": f(az) + f(el)}[cmd]
    a, e = b"AZ=" + _signed3(az), b"EL=" + _signed3(el)
    return {"C": a, "B": e, "C2": a + profile.c2_separator + e}[cmd]


def format_table_status(profile: Gs232Profile, current: int, total: int) -> bytes:
    if profile.n_style == "count":
        return b"%d" % total
    return b"+%04d+%04d" % (current, total)


# Driver ----------------------------------------------------------------------------------------

def _check_seconds(key: str, value: object, allow_zero: bool = True) -> None:
    # A NaN or infinite duration makes every deadline comparison false: the driver would hang.
    ok = (isinstance(value, numbers.Real) and math.isfinite(value)
          and (float(value) >= 0 if allow_zero else float(value) > 0))
    if not ok:
        raise ConfigError(f"{key} = {value!r} is invalid; use a finite number of seconds "
                          f"{'>= 0' if allow_zero else '> 0'}")


_DIRECTIONS: dict[str, Turn] = {"cw": Turn("cw"), "ccw": Turn("ccw"), "up": Turn("up"),
                                 "down": Turn("down"), "right": Turn("cw"),
                                 "left": Turn("ccw")}


class Gs232Driver(LinkDriver):
    """Driver for one GS-232-class controller on an open port.

    One request at a time (a lock); stale input is flushed before each request; each read is
    bounded by ``timeout_s``, measured on the port's time (:func:`tracker.transport.io_clock`:
    real time on a real port, whatever ``clock`` a simulation runs on); queries are retried
    ``retries`` times on ``?>`` or silence; set commands are never retried (a repeated move is not
    harmless). Profiles without handshake get at least ``pace_cmd_s`` between commands and
    optionally ``pace_char_s`` between bytes.
    """

    raw_terminator = CR

    def __init__(self, port: Port, profile: str | Gs232Profile = "gs232b", *,
                 timeout_s: float = 1.0, retries: int = 2, has_elevation: bool = True,
                 az_max_deg: float = 450.0, el_max_deg: float = 180.0,
                 pace_cmd_s: float | None = None, pace_char_s: float = 0.0,
                 ack_timeout_s: float = 0.3,
                 clock: Clock | None = None) -> None:
        _check_seconds("timeout_s", timeout_s, allow_zero=False)
        _check_seconds("ack_timeout_s", ack_timeout_s, allow_zero=False)
        _check_seconds("pace_char_s", pace_char_s)
        if pace_cmd_s is not None:
            _check_seconds("pace_cmd_s", pace_cmd_s)
        if not (isinstance(retries, (int, numbers.Integral)) and retries >= 0):
            raise ConfigError(f"retries = {retries!r} is invalid; use a whole number >= 0")
        self.port = port
        self.profile = get_profile(profile)
        self.timeout_s = float(timeout_s)
        self.retries = int(retries)
        self.az_max_deg = float(az_max_deg)
        self._az_max_configured_deg = self.az_max_deg
        self.el_max_deg = float(el_max_deg)
        self.link = ByteLink(port, clock, (self.profile.pace_cmd_s if pace_cmd_s is None
                                           else float(pace_cmd_s)), float(pace_char_s))
        self.ack_timeout_s = float(ack_timeout_s)
        self.clock = self.link.clock
        self.io_clock = self.link.io_clock      # deadlines and pacing: the wire's time
        self.capabilities = self.profile.capabilities(has_elevation, az_max_deg, el_max_deg)
        self.stop_on_exit = True
        self._lock = self.link.lock
        self._framer = LineFramer(b"\r\n", keep_empty=True)
        self._lines: list[bytes] = []

    @classmethod
    def from_url(cls, url: str, profile: str | Gs232Profile = "gs232b", *,
                 baudrate: int | None = None, rtscts: bool | None = None,
                 autobaud: bool = False, **kw: Any) -> Gs232Driver:
        """Open ``url`` (any pyserial URL) with the profile's serial settings."""
        prof = get_profile(profile)
        drv = driver_on_port(cls, url, prof, port_kw=dict(
            baudrate=baudrate or prof.baudrate, timeout_s=0.05,
            rtscts=prof.rtscts if rtscts is None else rtscts, clock=kw.get("clock")), **kw)
        if autobaud:
            try:
                drv.autobaud()
            except BaseException:
                drv.close()
                raise
        return drv

    @property
    def pace_cmd_s(self) -> float:
        return self.link.pace_cmd_s

    @property
    def pace_char_s(self) -> float:
        return self.link.pace_char_s

    # Low-level I/O: the shared link (tracker.protocols.link) translates pyserial errors -------

    def _write(self, data: bytes) -> None:
        self.link.write(data)

    def _read_some(self, remaining_s: float) -> bytes:
        return self.link.read_some(remaining_s)

    def _flush_input(self) -> None:
        self.link.flush_input()
        self._framer.clear()
        self._lines.clear()

    def _next_line(self, deadline: float, *, skip_empty: bool = True) -> bytes | None:
        """The next line before ``deadline`` (monotonic), or None on timeout."""
        while True:
            while self._lines:
                line = self._lines.pop(0)
                if line or not skip_empty:
                    return line
            remaining = deadline - self.io_clock.monotonic()
            if remaining <= 0:
                return None
            chunk = self._read_some(remaining)
            if chunk:
                self._lines.extend(self._framer.feed(chunk))

    # Requests ----------------------------------------------------------------------------------

    def _query(self, cmd: bytes) -> bytes:
        """Send ``cmd`` and return its one-line reply; retries on ``?>`` and silence."""
        name = cmd.decode("ascii", "replace")
        last: Exception | None = None
        with self._lock:
            for _attempt in range(1 + self.retries):
                self._flush_input()
                self._write(cmd + CR)
                line = self._next_line(self.io_clock.monotonic() + self.timeout_s)
                if line is None:
                    partial = self._framer.pending
                    last = RotatorTimeout(
                        f"no reply to {name} within {self.timeout_s:g} s"
                        + (f" (partial line {partial!r})" if partial else "")
                        + "; check the port, baud rate and that the controller is on")
                    continue
                if is_error_reply(line):
                    last = ProtocolError(f"controller rejected {name} with ?>", line)
                    continue
                if line.strip().upper() == cmd.upper():
                    raise ProtocolError(f"controller echoed {name}; echo is not GS-232 "
                                        f"behaviour (wrong protocol or a local-echo adapter?)",
                                        line)
                if line.lstrip().startswith(b"RPRT"):
                    # what Hamlib's rotctld answers to a command it does not know
                    raise ProtocolError(f"a Hamlib rotctld answered {name}, not a GS-232 "
                                        "controller: talk to it with protocol rotctld "
                                        "(port HOST:PORT)", line)
                return line
        assert last is not None
        raise last

    def _command(self, cmd: bytes) -> None:
        """Send a set/move command; profiles that acknowledge get their ack consumed."""
        with self._lock:
            self._flush_input()
            self._write(cmd + CR)
            if not self.profile.set_ack and not self.profile.k3ng_messages:
                return
            line = self._next_line(self.io_clock.monotonic() + self.ack_timeout_s,
                                   skip_empty=False)
            if line is not None and is_error_reply(line):
                raise ProtocolError(f"controller rejected {cmd.decode('ascii', 'replace')}",
                                    line)

    # Public API --------------------------------------------------------------------------------

    def position(self) -> tuple[float, float | None]:
        if self.capabilities.has_elevation:
            line = self._query(encode(Query("C2")))
            az, el = parse_position(line, self.profile.second_field_max_deg)
            if el is None:
                raise ProtocolError("C2 reply has no elevation", line)
            return az, el
        return parse_position(self._query(encode(Query("C"))))[0], None

    def elevation(self) -> float:
        return parse_elevation(self._query(encode(Query("B"))), self.profile.second_field_max_deg)

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        if not self.capabilities.has_elevation:
            el_deg = None
        self._command(encode(goto_message(az_deg, el_deg, az_max_deg=self.az_max_deg,
                                          el_max_deg=self.el_max_deg)))

    def stop(self) -> None:
        self._command(encode(Stop("all")))

    def stop_axis(self, axis: Literal["az", "el"]) -> None:
        if axis not in ("az", "el"):
            raise ValueError(f"axis must be 'az' or 'el', got {axis!r}")
        self._command(encode(Stop(axis)))

    def move(self, direction: Direction) -> None:
        """Start turning cw/ccw/up/down until stopped or at the end of travel."""
        cmd = _DIRECTIONS.get(str(direction).lower())
        if cmd is None:
            raise ValueError(f"direction must be one of cw, ccw, up, down; got {direction!r}")
        self._command(encode(cmd))

    def set_speed(self, step: int) -> None:
        """Azimuth speed X1 (slowest) .. X4 (fastest)."""
        if step not in (1, 2, 3, 4):
            raise LimitError(f"speed step {step!r} is invalid; allowed 1..4")
        self._command(encode(Speed(step)))

    def _need_b(self, what: str) -> None:
        if not self.profile.b_commands:
            raise ConfigError(f"{what} is a GS-232B command; profile {self.profile.name} "
                              f"does not have it")

    def set_mode_450(self, enabled: bool = True) -> None:
        """P45 / P36. In 360 mode the controller refuses azimuths above 360 with ``?>``, which
        a real GS-232B sends for a set command nobody reads: the driver narrows its own limit
        so such a goto raises :class:`LimitError` instead of being lost silently."""
        self._need_b("P45/P36")
        self._command(encode(SetMode450(enabled)))
        self.az_max_deg = (self._az_max_configured_deg if enabled
                           else min(self._az_max_configured_deg, 360.0))
        self.capabilities = replace(self.capabilities, az_max_deg=self.az_max_deg)

    def toggle_centre(self) -> None:
        self._need_b("Z")
        self._command(encode(ToggleCentre()))

    def upload_table(self, interval_s: int, points: Sequence) -> None:
        """Long-form M (azimuths) or W ((az, el) pairs); the controller turns to point 1."""
        n = len(points)
        pairs = n > 0 and not isinstance(points[0], (int, float))
        limit = self.profile.max_table_pairs if pairs else self.profile.max_table_points
        if pairs and not self.capabilities.has_elevation:
            raise LimitError("this rotator has no elevation: upload azimuths (M), not pairs")
        lo = 1 if pairs else self.profile.min_table_points
        if not (lo <= n <= limit):
            raise LimitError(f"{n} table points; profile {self.profile.name} takes "
                             f"{lo}..{limit} {'pairs' if pairs else 'angles'}")
        line = encode_table(interval_s, points, az_max_deg=self.az_max_deg,
                            el_max_deg=self.el_max_deg)
        if len(line) - 1 > self.profile.max_line_chars:
            raise LimitError(f"table line of {len(line) - 1} chars exceeds the "
                             f"{self.profile.max_line_chars}-char limit of "
                             f"{self.profile.name}; split the table")
        self._command(line[:-1])

    def start_table(self) -> None:
        self._command(encode(StartTable()))

    def table_status(self) -> tuple[int | None, int]:
        return parse_table_status(self._query(encode(TableStatus())))

    def help(self, page: int = 1) -> str:
        if page not in (1, 2, 3):
            raise ValueError("help page must be 1, 2 or 3")
        page_text: Literal["", "2", "3"] = "" if page == 1 else "2" if page == 2 else "3"
        return self._collect(encode(Help(page_text)) + CR, 0.2).decode("ascii", "replace")

    def autobaud(self, attempts: int = 10, interval_s: float = 0.3) -> None:
        """GS-232B power-up autobaud: send CR until the unit says Connect OK (bounded)."""
        with self._lock:
            self._flush_input()
            seen = bytearray()
            for _ in range(attempts):
                self._write(CR)
                deadline = self.io_clock.monotonic() + interval_s
                while self.io_clock.monotonic() < deadline:
                    seen += self._read_some(deadline - self.io_clock.monotonic())
                    if b"CONNECT OK" in seen.upper():
                        self._flush_input()
                        return
            raise RotatorTimeout(f"no 'Connect OK' after {attempts} CRs; power-cycle the "
                                 f"GS-232B and retry within 15 s (received {bytes(seen)!r})")


def open_gs232(protocol: str, url: str, **kw: Any) -> Gs232Driver:
    """The registry's driver factory: ``protocol`` is the dialect (a :data:`PROFILES` key)."""
    return Gs232Driver.from_url(url, protocol, **kw)
