"""GS-232B-AZ/AZ (dual azimuth, VE2DX proposal; docs/protocols.md) driver.

Two azimuth-only antennas behind one GS-232B-class interface: azimuth 2 uses the elevation
channel (``C2`` → ``AZ=aaaEL=bbb``, ``B``, ``U``/``D``/``E``) plus ``MBxxx``/``XBn``, and
``Y``/``Ynnn``/``Y999`` sync azimuth 2 to azimuth 1 with an offset. The byte I/O is
:class:`tracker.protocols.gs232.Gs232Driver` with an AZ/AZ profile.

Use cases:

* two antennas, two targets: ``drv.axis(1)`` and ``drv.axis(2)`` are az-only
  :class:`RotatorDriver` views (``goto`` → ``Maaa`` / ``MBaaa``; ``stop`` → ``A`` / ``E``,
  never ``S``, as the proposal advises, so stopping one never stops the other);
* one tracks, the other holds: drive ``axis(1)``, leave ``axis(2)`` alone;
* both synced with an offset: ``drv.sync(offset_deg)``, then drive ``axis(1)``;
  ``drv.unsync()`` cancels. While synced the controller ignores azimuth-2 commands, so
  ``axis(2).goto`` raises and ``axis(2).stop`` sends ``A`` (which then stops both).

The top-level driver is itself the azimuth-1 view plus ``positions()``/``goto_both()``; its
``stop()`` is ``S`` (both), which every exit path sends. ``open_driver(url, "gs232b-azaz2")``
gives the azimuth-2 view directly (closing it closes the port), for ``tracker track``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

from tracker.clock import Clock
from tracker.errors import LimitError
from tracker.protocols.base import Capabilities, Direction, RotatorDriver
from tracker.protocols.gs232 import Gs232Driver, Gs232Profile, parse_table_status
from tracker.protocols.gs232_codec import (
    Goto,
    GotoB,
    Speed,
    SpeedB,
    StartTable,
    StartTableB,
    Stop,
    Sync,
    TableB,
    TableStatus,
    TableStatusB,
    Turn,
    Unsync,
    encode,
    table_message,
)
from tracker.protocols.gs232_tables import field3
from tracker.protocols.link import driver_on_port
from tracker.transport import Port

AZAZ_PROFILE = Gs232Profile(
    name="gs232b-azaz", family="b", c2_separator=b"", set_ack=b"", b_commands=True,
    help_pages=("", "2", "3"), baudrate=9600, second_field_max_deg=450,
    description="GS-232B-AZ/AZ dual azimuth (VE2DX proposal): AZ=aaaEL=bbb with azimuth 2 "
                "in the EL field, silent set commands")
AXIS_CAPS = Capabilities(has_elevation=False, has_step_tables=True,
                         max_table_points=AZAZ_PROFILE.max_table_points, az_max_deg=360.0,
                         el_max_deg=0.0)


class AzAzDriver(RotatorDriver):
    def __init__(self, port: Port, *, timeout_s: float = 1.0, retries: int = 2,
                 az_max_deg: float = 360.0, clock: Clock | None = None, **_generic: Any):
        # _generic: has_elevation / el_max_deg / autobaud, which generic callers pass to
        # every driver; each AZ/AZ antenna is azimuth-only.
        self.az_max_deg = min(float(az_max_deg), 360.0)
        self.io = Gs232Driver(port, AZAZ_PROFILE, timeout_s=timeout_s, retries=retries,
                              has_elevation=True, az_max_deg=self.az_max_deg,
                              el_max_deg=self.az_max_deg, clock=clock)
        self.capabilities = Capabilities(has_elevation=False, has_speed=True,
                                         az_max_deg=self.az_max_deg, el_max_deg=0.0)
        self.sync_offset: int | None = None
        self.stop_on_exit = True
        self._axes = {1: AzAzAxis(self, 1), 2: AzAzAxis(self, 2)}

    @classmethod
    def from_url(cls, url: str, *, baudrate: int | None = None, rtscts: bool = False,
                 **kw: Any) -> AzAzDriver:
        return driver_on_port(cls, url, port_kw=dict(
            baudrate=baudrate or AZAZ_PROFILE.baudrate, timeout_s=0.05, rtscts=rtscts,
            clock=kw.get("clock")), **kw)

    def axis(self, n: Literal[1, 2]) -> AzAzAxis:
        if n not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {n!r}")
        return self._axes[n]

    # Both antennas ----------------------------------------------------------------------------

    def positions(self) -> tuple[float, float]:
        """(azimuth 1, azimuth 2) from one ``C2``."""
        az1, az2 = self.io.position()
        assert az2 is not None, "the AZ/AZ profile reads both azimuths"
        return az1, float(az2)

    def goto_both(self, az1_deg: float, az2_deg: float) -> None:
        self._bearing(az2_deg)
        self.io.goto(self._bearing(az1_deg), az2_deg)

    def sync(self, offset_deg: float = 0.0) -> None:
        """``Y`` / ``Ynnn``: azimuth 2 follows azimuth 1 + ``offset_deg`` (0..360)."""
        off = round(float(offset_deg))
        if not 0 <= off <= 360:
            raise LimitError(f"sync offset {offset_deg!r} deg is invalid; allowed 0..360")
        self.io._command(encode(Sync(field3(off, "offset", 0, 360))))
        self.sync_offset = off % 360

    def unsync(self) -> None:
        self.io._command(encode(Unsync()))
        self.sync_offset = None

    def set_speed(self, step: int, axis: Literal[1, 2] = 1) -> None:
        if step not in (1, 2, 3, 4):
            raise LimitError(f"speed step {step!r} is invalid; allowed 1..4")
        self.io._command(encode(Speed(step) if axis == 1 else SpeedB(step)))

    def stop(self) -> None:
        """``S``: both antennas."""
        self.io.stop()

    def _bearing(self, az_deg: float) -> float:
        field3(az_deg, "azimuth", 0, self.az_max_deg)   # raises LimitError, sends nothing
        return float(az_deg)

    # RotatorDriver API: azimuth 1 -----------------------------------------------------------

    def position(self) -> tuple[float, float | None]:
        return self._axes[1].position()

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        self._axes[1].goto(az_deg)

    def stop_axis(self, axis: Literal["az", "el"]) -> None:
        self.io.stop_axis(axis)

    def raw(self, cmd: str | bytes, quiet_s: float = 0.2) -> bytes:
        return self.io.raw(cmd, quiet_s)

    def close(self) -> None:
        self.io.close()


class AzAzAxis(RotatorDriver):
    """One antenna of an AZ/AZ interface as an azimuth-only driver."""

    def __init__(self, parent: AzAzDriver, n: Literal[1, 2], owns_port: bool = False):
        self.parent = parent
        self.n = n
        self.owns_port = owns_port
        self.capabilities = AXIS_CAPS
        self.stop_on_exit = True

    def position(self) -> tuple[float, float | None]:
        if self.n == 1:
            return self.parent.io.position()[0], None
        return self.parent.io.elevation(), None

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        p = self.parent
        a = field3(az_deg, "azimuth", 0, p.az_max_deg)
        if self.n == 2 and p.sync_offset is not None:
            raise LimitError("azimuth 2 is synced to azimuth 1 (Y); the controller ignores "
                             "MB now: drive axis 1 or unsync() first")
        p.io._command(encode(Goto(a) if self.n == 1 else GotoB(a)))

    def stop(self) -> None:
        # A / E, never S: stopping one antenna must not stop the other (proposal §7.5).
        self.parent.io._command(encode(Stop(
            "az" if self.n == 1 or self.parent.sync_offset is not None else "el")))

    def move(self, direction: Direction) -> None:
        d = str(direction).lower()
        if d not in ("cw", "ccw"):
            raise ValueError("an azimuth axis turns cw or ccw")
        turn = {(1, "cw"): Turn("cw"), (1, "ccw"): Turn("ccw"), (2, "cw"): Turn("up"),
                (2, "ccw"): Turn("down")}
        self.parent.io._command(encode(turn[(self.n, d)]))

    def set_speed(self, step: int) -> None:
        self.parent.set_speed(step, self.n)

    # Timed stepping: M / T / N for antenna 1, MB / TB / NB for antenna 2 ------------------

    def upload_table(self, interval_s: int, points: Sequence[float]) -> None:
        """Long-form ``Msss aaa bbb ...`` (``MBsss ...`` for antenna 2): azimuths only."""
        p = self.parent
        if len(points) and not isinstance(points[0], (int, float)):
            raise LimitError("an AZ/AZ antenna is azimuth-only: upload azimuths, not pairs")
        if not 2 <= len(points) <= AZAZ_PROFILE.max_table_points:
            raise LimitError(f"{len(points)} table points; allowed 2.."
                             f"{AZAZ_PROFILE.max_table_points}")
        if self.n == 2 and p.sync_offset is not None:
            raise LimitError("azimuth 2 is synced to azimuth 1 (Y): unsync() first")
        table = table_message(interval_s, points, az_max_deg=p.az_max_deg)
        p.io._command(encode(table if self.n == 1 else TableB(table.line)))

    def start_table(self) -> None:
        self.parent.io._command(encode(StartTable() if self.n == 1 else StartTableB()))

    def table_status(self) -> tuple[int | None, int]:
        return parse_table_status(self.parent.io._query(
            encode(TableStatus() if self.n == 1 else TableStatusB())))

    def close(self) -> None:
        if self.owns_port:
            self.parent.close()


def open_azaz(protocol: str, url: str, **kw: Any) -> AzAzDriver | AzAzAxis:
    """The registry's driver factory: "gs232b-azaz" drives antenna 1 (and reaches antenna 2
    through ``axis(2)``), "gs232b-azaz2" antenna 2 alone."""
    parent = AzAzDriver.from_url(url, **kw)
    if protocol.lower() == "gs232b-azaz2":
        return AzAzAxis(parent, 2, owns_port=True)
    return parent
