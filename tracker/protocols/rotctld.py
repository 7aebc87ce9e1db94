"""Hamlib ``rotctld`` network client: drive any rotator Hamlib knows.

Wire protocol (rotctld's default, non-extended responses): one command per line ending in
LF; ``P az el`` → ``RPRT n``; ``p`` → two lines ``az`` and ``el`` (or ``RPRT -n``); ``S``
stop, ``K`` park, ``M dir speed`` (dir 2 up, 4 down, 8 CCW, 16 CW; speed 1-100), ``_``
info line, ``\\dump_caps`` → the backend's capability dump ending ``RPRT 0``. Hamlib's
``RPRT -n`` codes are mapped to the project's errors (:data:`RPRT_ERRORS`).

Limits: the client checks every position against the configured limits *and* the limits the
daemon's backend reports (``Min Azimuth:`` etc. in ``\\dump_caps``), whichever is narrower,
before sending anything. The connection is a TCP socket opened through
:func:`tracker.transport.open_port` (``socket://host:port``); ``rotctld://host:port`` and
``host:port`` are accepted too (default port 4533).
"""

from __future__ import annotations

import re
from typing import Any, Literal

from tracker.clock import Clock
from tracker.errors import (
    ConfigError,
    LimitError,
    ProtocolError,
    RotatorIOError,
    RotatorTimeout,
)
from tracker.protocols.base import Capabilities, Direction
from tracker.protocols.link import ByteLink, LinkDriver, driver_on_port
from tracker.transport import Port

DEFAULT_PORT = 4533
# Hamlib 4.5 rig.h: enum rig_errcode_e (RPRT -n), text as rigerror() prints it.
HAMLIB_ERRORS = {
    1: "Invalid parameter", 2: "Invalid configuration", 3: "Memory shortage",
    4: "Feature not implemented", 5: "Communication timed out", 6: "IO error",
    7: "Internal Hamlib error", 8: "Protocol error", 9: "Command rejected by the rig",
    10: "Command performed, but arg truncated", 11: "Feature not available",
    12: "Target VFO unaccessible", 13: "Communication bus error",
    14: "Communication bus collision", 15: "NULL RIG handle or invalid pointer parameter",
    16: "Invalid VFO", 17: "Argument out of domain of func", 18: "Function deprecated",
    19: "Security error", 20: "Rig is not powered on",
}
RPRT_ERRORS: dict[int, type[Exception]] = {
    1: LimitError, 15: LimitError, 17: LimitError,
    2: ConfigError, 4: ConfigError, 11: ConfigError, 18: ConfigError,
    5: RotatorTimeout,
    8: ProtocolError, 9: ProtocolError, 10: ProtocolError,
}
MOVE_CODES = {"up": 2, "down": 4, "ccw": 8, "left": 8, "cw": 16, "right": 16}
_RPRT_RE = re.compile(rb"RPRT (-?\d+)")
_CAPS_RE = re.compile(rb"^(Min|Max) (Azimuth|Elevation):\s*(-?\d+(?:\.\d*)?)[ \t]*\r?$", re.M)


def rotctld_url(address: str) -> str:
    """``rotctld://h:p``, ``socket://h:p``, ``h:p`` or ``h`` → ``socket://h:p``."""
    a = address.strip()
    for prefix in ("rotctld://", "socket://", "tcp://"):
        if a.startswith(prefix):
            a = a[len(prefix):]
            break
    a = a.rstrip("/")
    host, _, port = a.rpartition(":") if ":" in a else (a, "", str(DEFAULT_PORT))
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"rotctld address {address!r} is invalid; use host:port, e.g. "
                          f"127.0.0.1:4533 or rotctld://127.0.0.1:4533")
    return f"socket://{host}:{int(port)}"


def rprt_error(code: int, what: str) -> Exception:
    """The project's error for ``RPRT -code`` answering ``what``."""
    n = abs(code)
    text = HAMLIB_ERRORS.get(n, "unknown Hamlib error")
    cls = RPRT_ERRORS.get(n, RotatorIOError)
    msg = f"rotctld: {what} failed: RPRT {code} ({text})"
    if cls is ProtocolError:
        return ProtocolError(msg)
    return cls(msg)



class RotctldDriver(LinkDriver):
    """A rotctld client. ``has_elevation`` False: ``p`` elevation is dropped and ``P`` sends
    elevation 0 (Hamlib's az-only backends ignore it)."""

    raw_terminator = b"\n"

    def __init__(self, port: Port, *, timeout_s: float = 2.0, has_elevation: bool = True,
                 az_min_deg: float = -180.0, az_max_deg: float = 450.0,
                 el_min_deg: float = 0.0, el_max_deg: float = 180.0,
                 check_limits: bool = True, read_caps: bool = True,
                 clock: Clock | None = None, autobaud: bool = False):
        # autobaud is what generic callers pass to every driver; a TCP daemon has none.
        self.link = ByteLink(port, clock)
        self.clock = self.link.clock
        self.timeout_s = float(timeout_s)
        self.check_limits = check_limits
        self.az_limits = (float(az_min_deg), float(az_max_deg))
        self.el_limits = (float(el_min_deg), float(el_max_deg))
        self.daemon_limits: dict[str, float] = {}
        if read_caps:
            self.daemon_limits = self._read_caps()
            d = self.daemon_limits
            self.az_limits = (max(self.az_limits[0], d.get("Min Azimuth", -1e9)),
                              min(self.az_limits[1], d.get("Max Azimuth", 1e9)))
            self.el_limits = (max(self.el_limits[0], d.get("Min Elevation", -1e9)),
                              min(self.el_limits[1], d.get("Max Elevation", 1e9)))
        self.capabilities = Capabilities(
            has_elevation=has_elevation, has_position_query=True, has_axis_stop=False,
            has_manual_move=True, has_speed=True, speed_steps=100,
            az_max_deg=self.az_limits[1], el_max_deg=self.el_limits[1] if has_elevation
            else 0.0)
        self.stop_on_exit = True

    @classmethod
    def from_url(cls, url: str, *, baudrate: int | None = None, **kw: Any) -> RotctldDriver:
        return driver_on_port(cls, rotctld_url(url), port_kw=dict(timeout_s=0.05), **kw)

    # Requests ----------------------------------------------------------------------------------

    def _request(self, cmd: str, lines: int) -> list[bytes]:
        """Send ``cmd``; return ``lines`` reply lines, or raise on ``RPRT -n`` / timeout."""
        data = (cmd + "\n").encode("ascii")

        def done(buf: bytes) -> tuple[str, int] | None:
            m = _RPRT_RE.search(buf)
            if m and buf.endswith(b"\n"):
                return ("rprt", int(m.group(1)))
            if lines and buf.count(b"\n") >= lines:
                return ("data", 0)
            return None

        with self.link.lock:
            self.link.flush_input()
            self.link.write(data)
            buf, found = self.link.read_until(done, self.timeout_s)
        if found is None:
            raise RotatorTimeout(f"rotctld: no reply to {cmd!r} within {self.timeout_s:g} s"
                                 + (f" (received {buf!r})" if buf else "")
                                 + "; is rotctld running and its rotator answering?")
        kind, code = found
        if kind == "rprt" and code != 0:
            raise rprt_error(code, cmd)
        return buf.split(b"\n")[:lines] if kind == "data" else []

    def _read_caps(self) -> dict[str, float]:
        with self.link.lock:
            self.link.flush_input()
            self.link.write(b"\\dump_caps\n")
            buf, found = self.link.read_until(
                lambda b: bool(_RPRT_RE.search(b)) and b.endswith(b"\n"), self.timeout_s)
        if not found:
            raise RotatorTimeout(f"rotctld: no reply to \\dump_caps within {self.timeout_s:g} s"
                                 f"; is this a rotctld (not rigctld) on that port?")
        return {f"{m.group(1).decode()} {m.group(2).decode()}": float(m.group(3))
                for m in _CAPS_RE.finditer(buf)}

    def _check(self, az: float, el: float) -> None:
        if not self.check_limits:
            return
        lo, hi = self.az_limits
        if not lo <= az <= hi:
            raise LimitError(f"azimuth {az:g} deg is outside {lo:g}..{hi:g} deg (configured "
                             f"and rotctld limits); nothing was sent")
        lo, hi = self.el_limits
        if not lo <= el <= hi:
            raise LimitError(f"elevation {el:g} deg is outside {lo:g}..{hi:g} deg "
                             f"(configured and rotctld limits); nothing was sent")

    # Public API --------------------------------------------------------------------------------

    def position(self) -> tuple[float, float | None]:
        lines = self._request("p", 2)
        try:
            az, el = float(lines[0]), float(lines[1])
        except (ValueError, IndexError) as e:
            raise ProtocolError("rotctld: p reply is not two numbers",
                                b"\n".join(lines)) from e
        return az, el if self.capabilities.has_elevation else None

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        try:
            az = float(az_deg)
            el = 0.0 if el_deg is None or not self.capabilities.has_elevation \
                else float(el_deg)
        except (TypeError, ValueError) as e:
            raise LimitError(f"position {az_deg!r} {el_deg!r} is not a number") from e
        if az != az or el != el:
            raise LimitError("position is NaN; nothing was sent")
        self._check(az, el)
        self._request(f"P {az:.2f} {el:.2f}", 0)

    def stop(self) -> None:
        self._request("S", 0)

    def park(self) -> None:
        self._request("K", 0)

    def move(self, direction: Direction | Literal["left", "right"], speed: int = 50) -> None:
        code = MOVE_CODES.get(str(direction).lower())
        if code is None:
            raise ValueError(f"direction must be one of {', '.join(MOVE_CODES)}")
        if not 1 <= int(speed) <= 100:
            raise LimitError(f"speed {speed!r} is invalid; allowed 1..100")
        self._request(f"M {code} {int(speed)}", 0)

    def info(self) -> str:
        return self._request("_", 1)[0].decode("ascii", "replace").strip()

    def close(self) -> None:
        if not self.link.closed:
            try:
                self.link.write(b"q\n")   # polite goodbye; rotctld closes its side
            except RotatorIOError:
                pass
        super().close()


def open_rotctld(protocol: str, url: str, **kw: Any) -> RotctldDriver:
    """The registry's driver factory."""
    return RotctldDriver.from_url(url, **kw)
