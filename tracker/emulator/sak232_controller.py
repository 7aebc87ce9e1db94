"""Virtual Zelpro SAK-232 controller (the only source is Zelpro's Quick User's Guide).

What the guide says, and the emulator does: 9600 8N1, no handshake; a command is one capital
letter, parameters separated by spaces, ended by ENTER. ``A aaa`` moves to azimuth 0-359
(no zero padding needed), ``R ±ddd`` moves relative and is clipped to the limits, ``O aaa``
assigns a known azimuth to the current position, ``K`` finds the limits (runs to the CCW hard
limit, then the CW one, and stores them as the soft limits), ``P pp ddd`` sets the gear ratio
(1 <= pp <= 999, 1 <= ddd <= 24, ddd <= pp, pp/ddd <= 24; the motor then moves in steps of
ddd/pp degrees), ``S`` stops at once.

Where the guide is silent, the choices (each an option of :class:`Sak232Options`):

* ENTER is CR; LF is ignored (``lf_is_enter`` makes LF end a command too).
* No echo (``echo`` echoes every byte, as some terminals expect).
* Commands are silent: no acknowledgement (``ack``) and no error token (``error``); an
  invalid command, a lower-case letter or an out-of-range number is ignored.
* No position query exists; ``gs23`` adds the GS-23 subset LOGGER sends when set to "Yaesu
  GS-23/GS-232" as the guide advises (``Mxxx``, ``S``, ``C`` → ``+0aaa``), so a GS-23
  client can read the position.
* ``A`` outside the soft limits goes to the nearest limit (the guide says so only for ``R``).
* The azimuth scale is the orientation: at power-up the CCW hard stop reads the rotator's
  ``stop_bearing_deg``; ``O`` shifts it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from tracker.clock import Clock
from tracker.emulator.rotorez_controller import ByteController, SessionState
from tracker.mount import PRESETS, RotatorSpec
from tracker.protocols import sak232 as codec
from tracker.protocols.gs232 import PROFILES, format_position

ZELPRO_RAU = PRESETS["Zelpro-RAU"]
GS23 = PROFILES["gs23"]     # the GS-23 subset's position reply, +0aaa


@dataclass
class Sak232Options:
    echo: bool = False
    ack: bytes = b""
    error: bytes = b""
    gs23: bool = False
    lf_is_enter: bool = False
    max_line: int = 64


class Sak232Controller(ByteController):
    name = "sak232"

    def __init__(self, spec: RotatorSpec | None = None, clock: Clock | None = None,
                 options: Sak232Options | None = None, az_deg: float | None = None):
        spec = spec or ZELPRO_RAU
        start_m = None if az_deg is None else (float(az_deg) - spec.stop_bearing_deg) % 360.0
        super().__init__(spec.with_(controller_maps_south=False), clock, start_m)
        self.options = options or Sak232Options()
        self.offset_deg = float(spec.stop_bearing_deg)   # scale reading at mech 0
        self.soft = (0.0, float(spec.az_span_deg))
        self.gear = (6, 4)
        self.k_phase = 0
        self._handlers: dict[type, Callable[[Any, float], bytes]] = {
            codec.Stop: self._on_stop, codec.GotoAz: self._on_goto,
            codec.Gs23Goto: self._on_goto, codec.MoveRelative: self._on_relative,
            codec.Orient: self._on_orient, codec.FindLimits: self._on_find_limits,
            codec.SetGear: self._on_gear, codec.Gs23Position: self._on_position,
            codec.Invalid: self._on_invalid,
        }

    # Frames: SAK-232 azimuth (orientation-shifted) <-> mechanical ------------------------

    def _mech_near(self, az: float) -> float:
        return (float(az) - self.offset_deg) % 360.0

    def bearing_of_mech(self, m: float) -> float:
        return (float(m) + self.offset_deg) % 360.0

    def readback(self) -> int:
        return round(self.bearing_of_mech(self.motor.az.position(self._now()))) % 360

    def _advance(self, now: float) -> None:
        """K: when the CCW run ends, start the CW run at that exact time; then store."""
        az = self.motor.az
        if self.k_phase and az.arrival_s() <= now and not az.jammed:
            t = az.arrival_s()
            if self.k_phase == 1:
                az.command(az.max_deg, t)
                self.k_phase = 2
                if az.arrival_s() <= now:
                    self._advance(now)
            else:
                self.soft = (az.min_deg, az.max_deg)
                self.k_phase = 0

    def antenna(self) -> float:
        with self._lock:
            self._advance(self._now())
            return super().antenna()

    def moving(self) -> bool:
        with self._lock:
            self._advance(self._now())
            return super().moving()

    def _clip(self, m: float) -> float:
        return min(max(m, self.soft[0]), self.soft[1])

    # Bytes ----------------------------------------------------------------------------------

    def handle(self, data: bytes, st: SessionState) -> bytes:
        out = bytearray()
        o = self.options
        if o.echo:
            out += data
        ends = b"\r\n" if o.lf_is_enter else b"\r"
        for b in data:
            c = bytes([b])
            if c == b"\n" and not o.lf_is_enter:
                continue
            if c in ends:
                line, st.buf = bytes(st.buf), bytearray()
                if line:
                    out += self._record(line + c, self._command(line))
                continue
            st.buf += c
            if len(st.buf) > o.max_line:
                st.buf.clear()
        return bytes(out)

    def _command(self, raw: bytes) -> bytes:
        """Decode one line with the driver's codec and hand the message to its handler."""
        t = self._now()
        self._advance(t)
        msg = codec.decode_command(raw)
        return self._handlers[type(msg)](msg, t)

    # Handlers: one per message type of the codec; each returns the reply bytes.

    def _on_stop(self, msg: codec.Stop, t: float) -> bytes:
        self.k_phase = 0
        self.motor.az.stop(t)
        return self.options.ack

    def _on_goto(self, msg: codec.GotoAz | codec.Gs23Goto, t: float) -> bytes:
        if isinstance(msg, codec.Gs23Goto) and not self.options.gs23:
            return self.options.error
        if isinstance(msg, codec.GotoAz):
            self.k_phase = 0
        self.motor.az.command(self._clip(self._mech_near(msg.az)), t)
        return self.options.ack

    def _on_relative(self, msg: codec.MoveRelative, t: float) -> bytes:
        self.k_phase = 0
        az = self.motor.az
        az.command(self._clip(az.position(t) + msg.delta_deg), t)
        return self.options.ack

    def _on_orient(self, msg: codec.Orient, t: float) -> bytes:
        self.offset_deg = (msg.az - self.motor.az.position(t)) % 360.0
        return self.options.ack

    def _on_find_limits(self, msg: codec.FindLimits, t: float) -> bytes:
        self.motor.az.command(self.motor.az.min_deg, t)
        self.k_phase = 1
        self._advance(t)
        return self.options.ack

    def _on_gear(self, msg: codec.SetGear, t: float) -> bytes:
        self.gear = (msg.pulses, msg.degrees)
        self.motor.az.stop(t)
        self.motor.az.resolution_deg = msg.degrees / msg.pulses
        return self.options.ack

    def _on_position(self, msg: codec.Gs23Position, t: float) -> bytes:
        if not self.options.gs23:
            return self.options.error
        return format_position(GS23, "C", self.readback(), 0) + GS23.reply_eol

    def _on_invalid(self, msg: codec.Invalid, t: float) -> bytes:
        return self.options.error

    def status_line(self) -> str:
        k = {0: "", 1: "  K: seeking CCW limit", 2: "  K: seeking CW limit"}[self.k_phase]
        return (f"{super().status_line()}  gear {self.gear[0]}/{self.gear[1]}  "
                f"offset {self.offset_deg:.0f}{k}")


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw) -> Sak232Controller:
    """The registry's emulator factory."""
    return Sak232Controller(spec, clock, **kw)
