"""Easycomm II / III driver (Hamlib rotator models 202 and 204; docs/protocols.md).

Text lines ended by LF, 9600 8N1 by default. ``goto`` sends ``AZaaa.a ELeee.e`` and expects
no reply; ``position`` sends ``AZ EL `` and reads one ``AZaaa.a ELeee.e`` line; ``stop``
sends ``SA SE ``. Controllers that answer a set or a stop with a position line (the SatNOGS
firmware answers ``SA SE``) leave that line unread: each query discards stale input first.
Wire degrees are the controller's own: 0-360 azimuth, 0-180 elevation at most.
"""

from __future__ import annotations

from typing import Any, Literal

from tracker.clock import Clock
from tracker.errors import ConfigError, ProtocolError, RotatorTimeout
from tracker.protocols import easycomm_codec as codec
from tracker.protocols.base import Capabilities, Direction
from tracker.protocols.framing import LineFramer
from tracker.protocols.link import ByteLink, LinkDriver, driver_on_port
from tracker.transport import Port

BAUDRATE = 9600
DIALECTS = ("easycomm2", "easycomm3")


class EasycommDriver(LinkDriver):
    """One Easycomm controller. ``retries``: extra attempts of a query that timed out or got
    an unreadable reply (set and move commands are never repeated)."""

    raw_terminator = codec.EOL

    def __init__(self, port: Port, protocol: str = "easycomm2", *, timeout_s: float = 1.0,
                 retries: int = 2, pace_cmd_s: float = 0.0, clock: Clock | None = None,
                 has_elevation: bool = True, az_max_deg: float | None = None,
                 el_max_deg: float | None = None, autobaud: bool = False):
        # autobaud is what generic callers pass to every driver; Easycomm has none.
        if protocol not in DIALECTS:
            raise ConfigError(f"Easycomm dialect {protocol!r} is unknown; known: "
                              f"{', '.join(DIALECTS)}")
        self.protocol = protocol
        self.link = ByteLink(port, clock, pace_cmd_s)
        self.clock = self.link.clock
        self.timeout_s = float(timeout_s)
        self.retries = int(retries)
        self.az_max_deg = min(codec.AZ_MAX_DEG, codec.AZ_MAX_DEG if az_max_deg is None
                              else float(az_max_deg))
        self.el_max_deg = min(codec.EL_MAX_DEG, codec.EL_MAX_DEG if el_max_deg is None
                              else float(el_max_deg))
        self.capabilities = Capabilities(
            has_elevation=has_elevation, has_position_query=True, has_axis_stop=True,
            has_manual_move=True, has_speed=False, speed_steps=0,
            az_max_deg=self.az_max_deg, el_max_deg=self.el_max_deg if has_elevation else 0.0)
        self.stop_on_exit = True

    @classmethod
    def from_url(cls, url: str, protocol: str = "easycomm2", *, baudrate: int | None = None,
                 **kw: Any) -> EasycommDriver:
        return driver_on_port(cls, url, protocol, port_kw=dict(
            baudrate=baudrate or BAUDRATE, timeout_s=0.05, clock=kw.get("clock")), **kw)

    # Requests ----------------------------------------------------------------------------------

    def _send(self, data: bytes) -> None:
        with self.link.lock:
            self.link.write(data)

    def _read_line(self) -> bytes | None:
        """The first complete line within the timeout, or None."""
        framer = LineFramer(b"\r\n", keep_empty=False, max_line=256)
        lines: list[bytes] = []
        fed = [0]

        def done(buf: bytes) -> bool:
            lines.extend(framer.feed(buf[fed[0]:]))
            fed[0] = len(buf)
            return bool(lines)

        _buf, found = self.link.read_until(done, self.timeout_s)
        return lines[0] if found else None

    def _query(self, data: bytes) -> bytes:
        """Send ``data``; the first reply line (retried on silence or an unreadable line)."""
        last: Exception | None = None
        for _attempt in range(self.retries + 1):
            try:
                with self.link.lock:
                    self.link.flush_input()
                    self.link.write(data)
                    line = self._read_line()
                if line is None:
                    raise RotatorTimeout(f"Easycomm: no reply to {data!r} within "
                                         f"{self.timeout_s:g} s; check the port, baud rate "
                                         f"and that the controller is on")
                codec.parse_position(line)
                return line
            except (RotatorTimeout, ProtocolError) as e:
                last = e
        assert last is not None
        raise last

    # Public API --------------------------------------------------------------------------------

    def position(self) -> tuple[float, float | None]:
        az, el = codec.parse_position(self._query(codec.QUERY))
        return az, el if self.capabilities.has_elevation else None

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        el = el_deg if self.capabilities.has_elevation else None
        self._send(codec.encode_goto(az_deg, el, az_max_deg=self.az_max_deg,
                                     el_max_deg=self.el_max_deg))

    def stop(self) -> None:
        self._send(codec.STOP)

    def stop_axis(self, axis: Literal["az", "el"]) -> None:
        self._send(codec.STOP_AXIS[axis])

    def move(self, direction: Direction) -> None:
        self._send(codec.MOVE[direction])



def open_easycomm(protocol: str, url: str, **kw: Any) -> EasycommDriver:
    """The registry's driver factory: ``protocol`` "easycomm2" or "easycomm3"."""
    return EasycommDriver.from_url(url, protocol, **kw)
