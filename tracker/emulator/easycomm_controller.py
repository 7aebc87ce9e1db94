"""Emulated Easycomm II / III controller (docs/protocols.md, "Easycomm").

Lines end at CR or LF; each line holds space-separated commands, decoded by the codec the
driver uses (:mod:`tracker.protocols.easycomm_codec`) and dispatched to one handler per
command type. Queries on one line are answered together on one line (``AZ EL`` →
``AZ120.0 EL30.0\\n``); set, move and stop commands are silent, except that with
``satnogs=True`` ``SA SE`` answers the position as the SatNOGS firmware does. Wire degrees
are the mechanical angles of the motor model (azimuth from the CCW stop), and ``VE`` answers
:attr:`EasycommOptions.version`. Unknown commands are ignored, as the firmware does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from tracker.clock import Clock
from tracker.emulator.rotorez_controller import ByteController, SessionState
from tracker.mount import MotorModel, RotatorSpec
from tracker.protocols import easycomm_codec as codec


@dataclass
class EasycommOptions:
    satnogs: bool = False               # SA SE answers the position line
    version: bytes = b"tracker-emulator"
    max_line: int = 256                 # a longer unterminated line is discarded


class EasycommController(ByteController):
    """``protocol`` "easycomm2" or "easycomm3" (which adds the ``VL``/``VR``/``VU``/``VD``
    rate moves); the emulated rotator is ``spec`` with its elevation axis."""

    def __init__(self, protocol: str = "easycomm2", spec: RotatorSpec | None = None,
                 clock: Clock | None = None, options: EasycommOptions | None = None,
                 az_deg: float | None = None, el_deg: float | None = None):
        super().__init__(spec, clock, az_deg)
        self.name = protocol
        self.options = options or EasycommOptions()
        self.motor = MotorModel(self.spec, az_deg, el_deg, t_s=self._now())
        self._handlers: dict[type, Callable[[Any, list[bytes]], None]] = {
            codec.SetAxis: self._set_axis, codec.Query: self._query,
            codec.StopAxis: self._stop_axis, codec.Move: self._move,
            codec.Version: self._version, codec.Unknown: self._ignore,
        }

    # State ------------------------------------------------------------------------------------

    def _axis(self, axis: Literal["az", "el"]):
        return self.motor.az if axis == "az" else self.motor.el

    def antenna(self) -> tuple[float, float | None]:
        """``(az, el)`` of the simulated antenna now, mechanical degrees."""
        with self._lock:
            az, el = self.motor.position(self._now())
            return float(az), float(el) if self.motor.el is not None else None

    def moving(self) -> bool:
        with self._lock:
            return self.motor.moving(self._now())

    def jam(self, axis: Literal["az", "el"] = "az", jammed: bool = True) -> None:
        with self._lock:
            motor = self._axis(axis)
            if motor is not None:
                motor.jam(self._now(), jammed)

    def power_cycle(self, reset_sessions: bool = False) -> None:
        with self._lock:
            self.motor.stop(self._now())

    def status_line(self) -> str:
        az, el = self.antenna()
        state = "moving" if self.moving() else "idle"
        el_text = "  --" if el is None else f"{el:5.1f}"
        return (f"{self.name}  az {az:6.1f}  el {el_text}  {state}  "
                f"cmds {self.commands_seen}")

    # Bytes ------------------------------------------------------------------------------------

    def handle(self, data: bytes, st: SessionState) -> bytes:
        out = bytearray()
        for b in data:
            c = bytes([b])
            if c in b"\r\n":
                line, st.buf = bytes(st.buf), bytearray()
                if line.strip():
                    out += self._record(line, self._line(line))
                continue
            st.buf += c
            if len(st.buf) > self.options.max_line:
                st.buf.clear()
        return bytes(out)

    def _line(self, line: bytes) -> bytes:
        fields: list[bytes] = []
        for cmd in codec.decode_line(line):
            self._handlers[type(cmd)](cmd, fields)
        if self.options.satnogs and line.split() == [b"SA", b"SE"]:
            self._query(codec.Query("az"), fields)
            self._query(codec.Query("el"), fields)
        return codec.format_reply(fields)

    # Handlers: one per command type; ``fields`` collects the line's answers.

    def _set_axis(self, cmd: codec.SetAxis, fields: list[bytes]) -> None:
        motor = self._axis(cmd.axis)
        if motor is not None:
            motor.command(cmd.deg, self._now())     # the motor clamps to the travel

    def _query(self, cmd: codec.Query, fields: list[bytes]) -> None:
        az, el = self.antenna()
        value = az if cmd.axis == "az" else (el or 0.0)
        fields.append(codec.format_value(cmd.axis, value))

    def _stop_axis(self, cmd: codec.StopAxis, fields: list[bytes]) -> None:
        motor = self._axis(cmd.axis)
        if motor is not None:
            motor.stop(self._now())

    def _move(self, cmd: codec.Move, fields: list[bytes]) -> None:
        if cmd.rate_mdeg_s is not None and self.name != "easycomm3":
            return                                   # VL/VR/VU/VD are Easycomm III only
        axis: Literal["az", "el"] = "az" if cmd.direction in ("ccw", "cw") else "el"
        motor = self._axis(axis)
        if motor is None:
            return
        end = motor.max_deg if cmd.direction in ("cw", "up") else motor.min_deg
        if cmd.rate_mdeg_s is not None and cmd.rate_mdeg_s <= 0:
            motor.stop(self._now())
            return
        motor.command(end, self._now())

    def _version(self, cmd: codec.Version, fields: list[bytes]) -> None:
        fields.append(b"VE" + self.options.version)

    def _ignore(self, cmd: codec.Unknown, fields: list[bytes]) -> None:
        return


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw) -> EasycommController:
    """The registry's emulator factory: ``protocol`` "easycomm2" or "easycomm3"."""
    return EasycommController(protocol, spec, clock, **kw)
