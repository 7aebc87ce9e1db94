"""Virtual Idiom Press Rotor-EZ / RotorCard and Hy-Gain DCU-1 controllers.

Byte-oriented, unlike the GS-232 line machine: option commands are single bytes with no
terminator and the ``AI1;`` reply has no terminator either. Served by ``serve_pty`` /
``serve_tcp`` like any controller (they only need ``open_session()`` returning an object
with ``feed(bytes) -> bytes`` and ``poll() -> bytes``).

Behaviour (docs/protocols.md): case-sensitive; ``AP1ddd\\r`` sets and goes (Rotor-EZ only),
``AP1ddd;`` sets, ``AM1;`` goes, ``AI1;`` → ``;ddd`` (0-359), ``;`` stops (Rotor-EZ),
``AS1;`` stops (DCU-1); option bytes ``E e O o S s J j`` switch endpoint / overshoot /
unstick / jam protection; ``V`` answers the banner. LF is ignored.

Choices where the sources are silent (each an option of :class:`RotorEzOptions`):
``banner``: a Rotor-EZ answers ``;`` while idle and any invalid command with
``C2000 IDIOM V1.4S `` (rotorez.txt); on by default, never on a DCU-1. ``power_on_byte``:
the first connection after "power-on" gets one stray byte (0xE0 seen on a real unit);
on by default for the Rotor-EZ. ``V`` answers with the banner text (undocumented format).
A DCU-1 is silent for everything and has no query: ``AI1;`` is ignored. Bearings are true
bearings; the motor runs in the mechanical frame of ``spec`` (default: a Hy-Gain HAM-IV
class rotator, 360 deg, south stop).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from tracker.clock import Clock, SystemClock
from tracker.emulator.gs232_controller import Faults
from tracker.mount import PRESETS, MotorModel, RotatorSpec
from tracker.protocols import rotorez as codec
from tracker.protocols.rotorez import BANNER

HAM_IV = PRESETS["HAM-IV"]


class ByteController:
    """Shared plumbing for byte-oriented controllers: clock, motor (azimuth), log, faults,
    sessions. Subclasses implement ``handle(data, state) -> bytes`` and may override
    ``poll_state``. Bearings on the wire are true bearings mapped through ``spec``."""

    name = "controller"

    def __init__(self, spec: RotatorSpec | None = None, clock: Clock | None = None,
                 az_deg: float | None = None):
        self.spec = spec or HAM_IV
        self.clock = clock or SystemClock()
        self.faults = Faults()
        self._lock = threading.RLock()
        start_m = None if az_deg is None else float(self.spec.frame.mech_of_wire(az_deg))
        self.motor = MotorModel(self.spec.with_(el_max_deg=None, el_rate_deg_s=None), start_m,
                                None, t_s=self.clock.monotonic())
        self.commands_seen = 0
        self.log: list[tuple[float, bytes, bytes]] = []   # (t, command, reply), last 200
        self.sessions_opened = 0

    def open_session(self) -> ByteSession:
        self.sessions_opened += 1
        return ByteSession(self, first=self.sessions_opened == 1)

    def _now(self) -> float:
        return self.clock.monotonic()

    # Frames: true bearing on the wire <-> mechanical in the motor --------------------------

    def mech_of_bearing(self, bearing: float) -> float:
        frame = self.spec.frame
        if frame.wire_takes_bearing and frame.az_span_deg > 360.0:
            # Like the GS-232B's south-centre mode: the lowest mechanical angle, so the stop
            # bearing itself is the CCW end; only a rotator with overlap (span > 360) has a
            # choice, and it takes the nearer way.
            cands = frame.mech_candidates(bearing % 360.0)
            if len(cands) > 1:
                here = float(self.motor.az.position(self._now()))
                return min(cands, key=lambda m: abs(m - here))
        return float(frame.mech_of_wire(bearing))

    def bearing_of_mech(self, m: float) -> float:
        return self.spec.frame.wire_of(m)

    def readback(self) -> int:
        """The controller's 0-359 reading now."""
        return round(self.bearing_of_mech(self.motor.az.position(self._now()))) % 360

    def antenna(self) -> float:
        """True bearing of the simulated antenna now (0 <= b < 360)."""
        with self._lock:
            return self.bearing_of_mech(self.motor.az.position(self._now())) % 360.0

    def moving(self) -> bool:
        with self._lock:
            return self.motor.az.moving(self._now())

    def jam(self, jammed: bool = True) -> None:
        with self._lock:
            self.motor.az.jam(self._now(), jammed)

    def status_line(self) -> str:
        state = "moving" if self.moving() else "idle"
        return f"{self.name}  az {self.antenna():6.1f}  {state}  cmds {self.commands_seen}"

    def _record(self, cmd: bytes, reply: bytes) -> bytes:
        self.commands_seen += 1
        self.log.append((self._now(), cmd, reply))
        del self.log[:-200]
        return reply

    def handle(self, data: bytes, state: SessionState) -> bytes:
        raise NotImplementedError

    def poll_state(self, state: SessionState) -> bytes:
        return b""


@dataclass
class SessionState:
    buf: bytearray = field(default_factory=bytearray)
    pending: bytearray = field(default_factory=bytearray)   # unsolicited output
    extra: dict = field(default_factory=dict)


class ByteSession:
    """One connection: its own input buffer; faults applied to everything sent back."""

    def __init__(self, controller: ByteController, first: bool = False):
        self.controller = controller
        self.state = SessionState()
        self.state.extra["first"] = first

    def feed(self, data: bytes) -> bytes:
        ctrl = self.controller
        if ctrl.faults.deaf:
            return b""
        with ctrl._lock:
            return self._filter(ctrl.handle(bytes(data), self.state))

    def poll(self) -> bytes:
        ctrl = self.controller
        with ctrl._lock:
            out = bytes(self.state.pending) + ctrl.poll_state(self.state)
            self.state.pending.clear()
        return self._filter(out)

    def next_output_in_s(self) -> float | None:
        """Seconds until unsolicited output (the power-on byte is due at once)."""
        return 0.0 if self.state.pending else None

    def _filter(self, reply: bytes) -> bytes:
        f = self.controller.faults
        if f.silent or not reply:
            return b""
        return f.reply_filter(reply) if f.reply_filter else reply


@dataclass
class RotorEzOptions:
    banner: bool | None = None          # None: on for the Rotor-EZ, off for the DCU-1
    power_on_byte: bytes | None = None  # None: b"\xe0" for the Rotor-EZ, nothing for DCU-1
    max_command: int = 16               # a longer unterminated command is discarded


class RotorEzController(ByteController):
    """``variant`` "rotorez" (Rotor-EZ / RotorCard) or "dcu1" (Hy-Gain DCU-1)."""

    def __init__(self, variant: Literal["rotorez", "dcu1"] = "rotorez",
                 spec: RotatorSpec | None = None, clock: Clock | None = None,
                 options: RotorEzOptions | None = None, az_deg: float | None = None):
        if variant not in ("rotorez", "dcu1"):
            raise ValueError(f"variant must be rotorez or dcu1, got {variant!r}")
        super().__init__(spec, clock, az_deg)
        self.variant = variant
        self.name = variant
        opts = options or RotorEzOptions()
        rez = variant == "rotorez"
        self.banner = rez if opts.banner is None else (opts.banner and rez)
        self.power_on_byte = (b"\xe0" if rez else b"") if opts.power_on_byte is None \
            else opts.power_on_byte
        self.max_command = opts.max_command
        self.target_bearing: int | None = None
        self.settings = {name: True for name in codec.OPTION_BYTES}
        self._handlers: dict[type, Callable[[Any], bytes]] = {
            codec.SetOption: self._on_option, codec.Version: self._on_version,
            codec.Stop: self._on_stop, codec.SetBearing: self._on_set_bearing,
            codec.Execute: self._on_execute, codec.QueryBearing: self._on_query,
            codec.StopAxis: self._on_stop_axis, codec.Invalid: self._on_invalid,
        }

    def open_session(self) -> ByteSession:
        s = super().open_session()
        if s.state.extra["first"] and self.power_on_byte:
            s.state.pending += self.power_on_byte
        return s

    def _go(self, bearing: int) -> None:
        self.motor.az.command(self.mech_of_bearing(bearing), self._now())

    def handle(self, data: bytes, st: SessionState) -> bytes:
        """Frame the bytes (a single-byte command only while nothing is pending), decode each
        command with the driver's codec and hand it to its handler."""
        out = bytearray()
        for b in data:
            c = bytes([b])
            if c == b"\n":
                continue
            if not st.buf:
                single = codec.decode_single(c)
                if single is not None and (self.variant == "rotorez"
                                           or isinstance(single, codec.Stop)):
                    out += self._record(c, self._handlers[type(single)](single))
                    continue
                if c == b"\r":
                    continue
            if c in (b";", b"\r"):
                cmd, st.buf = bytes(st.buf), bytearray()
                msg = codec.decode_command(cmd, c)
                out += self._record(cmd + c, self._handlers[type(msg)](msg))
                continue
            st.buf += c
            if len(st.buf) > self.max_command:
                st.buf.clear()
        return bytes(out)

    def _invalid(self) -> bytes:
        return BANNER if self.banner else b""

    # Handlers: one per message type of the codec; each returns the reply bytes.

    def _on_option(self, msg: codec.SetOption) -> bytes:
        self.settings[msg.name] = msg.enabled
        return b""

    def _on_version(self, msg: codec.Version) -> bytes:
        return BANNER

    def _on_stop(self, msg: codec.Stop) -> bytes:
        idle = not self.motor.az.moving(self._now())
        self.motor.az.stop(self._now())
        return BANNER if (self.variant == "rotorez" and idle and self.banner) else b""

    def _on_set_bearing(self, msg: codec.SetBearing) -> bytes:
        self.target_bearing = msg.bearing % 360
        if msg.go:
            if self.variant != "rotorez":
                return b""     # DCU-1: only the ; form exists
            self._go(self.target_bearing)
        return b""

    def _on_execute(self, msg: codec.Execute) -> bytes:
        if self.target_bearing is not None:
            self._go(self.target_bearing)
        return b""

    def _on_query(self, msg: codec.QueryBearing) -> bytes:
        if self.variant != "rotorez":
            return self._invalid()
        return codec.format_ai_reply(self.readback())

    def _on_stop_axis(self, msg: codec.StopAxis) -> bytes:
        self.motor.az.stop(self._now())
        return b""

    def _on_invalid(self, msg: codec.Invalid) -> bytes:
        return self._invalid()

    def status_line(self) -> str:
        opts = "".join(k[0].upper() if v else k[0] for k, v in self.settings.items())
        tgt = "---" if self.target_bearing is None else f"{self.target_bearing:03d}"
        return f"{super().status_line()}  target {tgt}  options {opts}"


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw) -> RotorEzController:
    """The registry's emulator factory: ``protocol`` "rotorez" or "dcu1"."""
    variant: Literal["rotorez", "dcu1"] = "dcu1" if protocol == "dcu1" else "rotorez"
    return RotorEzController(variant, spec, clock, **kw)
