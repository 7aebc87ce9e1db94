"""A virtual GS-232-class controller: bytes in, bytes out, antenna moved by the motor model.

One :class:`Gs232Controller` is one box (one antenna, one memory); each connection gets a
:class:`Session` with its own line buffer, like a second terminal on the same unit. Time comes
from an injected Clock: stepping tables and motor motion are evaluated at exact clock times, so
a SimClock with ``speed`` > 1 replays a pass quickly and a ManualClock makes tests exact.

A line is decoded by the drivers' codec (:mod:`tracker.protocols.gs232_codec`) into one
message, which ``_handlers`` maps to its handler; the replies are formatted by
:mod:`tracker.protocols.gs232`'s reply codec, which the driver parses.

Where the manuals are silent (docs/protocols.md, Step tables) the choices are: after the last table
point the antenna stays there (``end_behaviour``), S stops stepping, a short M/W stops stepping
but keeps the list, N answers with the current point while a list is loaded.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from tracker.clock import Clock, SystemClock
from tracker.emulator.help_text import help_screen
from tracker.errors import ProtocolError
from tracker.mount import MotorModel, MountFrame, RotatorSpec, preset
from tracker.protocols import gs232_codec as codec
from tracker.protocols.framing import LineFramer
from tracker.protocols.gs232 import (
    ERROR_REPLY,
    Gs232Profile,
    format_position,
    format_table_status,
    get_profile,
)

# What a GS-232B reads while the rotator's own control box is switched off (captured on real units).
OFF_AZ, OFF_EL = -1, -2
FULL_SCALE_INTERVAL_S = 0.5


@dataclass
class EmulatorOptions:
    """Deviations from the profile's defaults (the byte-faithful real-unit behaviour).

    ``strict_acks``: CR after every set command, as the manual says. ``one_space``: C2 with one
    space (the manual's text). ``readback_360``: C reports 0-359 even in 450 mode.
    ``end_behaviour``: "stay" on the last table point or "clear" the list (K3NG).
    ``autobaud``: ignore input until CRs arrive, then answer "Connect OK" (GS-232B power-up).
    """

    strict_acks: bool = False
    one_space: bool = False
    readback_360: bool = False
    end_behaviour: Literal["stay", "clear"] | None = None
    autobaud: bool = False
    autobaud_crs: int = 2
    max_line: int = 65536


@dataclass
class Faults:
    """Fault hooks; the server consults them on every exchange.

    ``silent``: read and act on commands but never answer. ``reply_filter``: transform every
    reply (drop or garble bytes). ``deaf``: ignore all input. ``wrongside``: read-back
    0-359 in 450 mode. ``step_clock_scale``: table step period factor (step clock drift).
    ``injector``: a :class:`tracker.emulator.faults.FaultInjector` running a scripted plan.
    """

    silent: bool = False
    deaf: bool = False
    reply_filter: Callable[[bytes], bytes] | None = None
    wrongside: bool = False
    step_clock_scale: float = 1.0
    injector: Any = None


@dataclass
class _Table:
    interval_s: int
    points: list[tuple[int, int | None]]
    index: int = 0            # 0-based current point
    running: bool = False
    next_t: float = 0.0


@dataclass
class _SessionState:
    calibration: str | None = None   # "O"/"O2" waiting for Y, "F"/"F2" streaming
    next_stream_t: float = 0.0
    connected: bool = True
    crs_seen: int = 0
    out: bytearray = field(default_factory=bytearray)


class Gs232Controller:
    """The controller state machine for one profile, driving :class:`MotorModel`."""

    # The largest value the second field of W takes (elevation; AZ/AZ: azimuth 2).
    el_field_max_deg = 180
    dialect: codec.Dialect = "gs232"

    def __init__(self, profile: str | Gs232Profile = "gs232b", spec: RotatorSpec | None = None,
                 clock: Clock | None = None, options: EmulatorOptions | None = None,
                 az_deg: float | None = None, el_deg: float | None = None):
        self.profile = get_profile(profile)
        self.options = options or EmulatorOptions()
        self.spec = spec or preset("G-5500")
        self.clock = clock or SystemClock()
        self.faults = Faults()
        self._lock = threading.RLock()
        self.motor = MotorModel(self.spec, az_deg, el_deg, t_s=self.clock.monotonic())
        self.mode_450 = self.spec.az_span_deg > 360.0
        self.south_centre = bool(self.spec.controller_maps_south)
        self.speed_step = 4
        self.rotator_on = True
        self.table: _Table | None = None
        self.commands_seen = 0
        self.power_epoch = 0              # bumped by power_cycle: sessions reset (autobaud)
        self.log: list[tuple[float, bytes, bytes]] = []   # (t, line, reply), last 200
        self._end = self.options.end_behaviour or self.profile.end_behaviour
        if self.options.one_space and self.profile.family == "b":
            self.profile = self.profile.with_(c2_separator=b" ")
        if self.options.strict_acks and not self.profile.set_ack:
            self.profile = self.profile.with_(set_ack=b"\r")
        self._handlers: dict[type, Callable[[Any, _SessionState, float], bytes]] = {
            codec.Query: self._on_query, codec.Stop: self._on_stop, codec.Turn: self._on_turn,
            codec.Speed: self._on_speed, codec.SetMode450: self._on_mode_450,
            codec.ToggleCentre: self._on_toggle_centre, codec.Calibrate: self._on_calibrate,
            codec.FullScale: self._on_full_scale, codec.Help: self._on_help,
            codec.StartTable: self._on_start_table, codec.TableStatus: self._on_table_status,
            codec.Goto: self._on_goto, codec.Table: self._on_table,
            codec.BadTable: self._on_bad_table, codec.Invalid: self._on_invalid,
        }

    # Sessions ----------------------------------------------------------------------------------

    def open_session(self) -> Session:
        return Session(self)

    # Fault injection and power -----------------------------------------------------------------

    def jam(self, axis: Literal["az", "el"] = "az", jammed: bool = True) -> None:
        """The named axis stops turning (motor stalled): commands are accepted, nothing moves."""
        with self._lock:
            motor = self.motor.az if axis == "az" else self.motor.el
            if motor is None:
                raise ValueError("this rotator has no elevation axis")
            motor.jam(self._now(), jammed)

    def set_rotator_power(self, on: bool) -> None:
        """Switch the rotator's control box off/on: the interface then reads AZ=-001 EL=-002."""
        with self._lock:
            t = self._now()
            if not on:
                self.motor.stop(t)
                if self.table:
                    self.table.running = False
            self.rotator_on = on

    def power_cycle(self, reset_sessions: bool = False) -> None:
        """Interface off and on again: memory and stepping lost, motors stopped.
        ``reset_sessions``: also lose half-received lines and need autobaud again (if on)."""
        with self._lock:
            self.motor.stop(self._now())
            self.table = None
            self.speed_step = 4
            self._apply_speed(self._now())
            if reset_sessions:
                self.power_epoch += 1

    # Introspection (tests, live status) --------------------------------------------------------

    def _now(self) -> float:
        return self.clock.monotonic()

    def antenna(self) -> tuple[float, float | None]:
        """Mechanical (az, el) of the simulated antenna now, after any due table steps."""
        with self._lock:
            t = self._now()
            self._advance(t)
            az, el = self.motor.position(t)
            return float(az), (float(el) if self.motor.el is not None else None)

    def moving(self) -> bool:
        with self._lock:
            t = self._now()
            self._advance(t)
            return self.motor.moving(t)

    def status_line(self) -> str:
        az, el = self.antenna()
        tab = ""
        if self.table:
            tab = (f"  table {self.table.index + 1}/{len(self.table.points)}"
                   f"{' running' if self.table.running else ''}")
        el_s = "" if el is None else f"  el {el:6.1f}"
        state = "moving" if self.moving() else "idle"
        power = "" if self.rotator_on else "  [rotator OFF]"
        return (f"{self.profile.name}  az {az:6.1f}{el_s}  X{self.speed_step}  {state}"
                f"  {'450' if self.mode_450 else '360'}{tab}  cmds {self.commands_seen}{power}")

    # Frames: wire degrees <-> mechanical ------------------------------------------------------

    def _wire_az_max(self) -> int:
        return 450 if self.mode_450 else 360

    def _wire_frame(self) -> MountFrame:
        """The frame the box's current mode puts on the wire: in south-centre 360 mode it
        takes bearings on a scale whose CCW end is south, else the mechanical angle."""
        south = self.south_centre and not self.mode_450
        return MountFrame(self.spec.az_span_deg, 180.0 if south else 0.0, south)

    def _mech_of_wire(self, az: int) -> float:
        return float(self._wire_frame().mech_of_wire(az))

    def _wire_of_mech(self, m: float) -> int:
        w = round(m)
        if self.south_centre and not self.mode_450:
            return round(self._wire_frame().wire_of(w))
        if self.mode_450:
            return w % 360 if (self.options.readback_360 or self.faults.wrongside) else w
        return w if w <= 360 else w % 360

    def _readback(self, t: float) -> tuple[int, int]:
        if not self.rotator_on:
            return OFF_AZ, OFF_EL
        az, el = self.motor.position(t)
        return self._wire_of_mech(az), round(el) if self.motor.el is not None else 0

    # Motion ------------------------------------------------------------------------------------

    def _apply_speed(self, t: float) -> None:
        rates = self.spec.az_speed_rates_deg_s
        if rates:
            self.motor.az.set_rate(rates[min(self.speed_step, len(rates)) - 1], t)

    def _goto(self, t: float, az: int | None, el: int | None) -> None:
        if not self.rotator_on:
            return
        if az is not None:
            self.motor.az.command(self._mech_of_wire(az), t)
        if el is not None and self.motor.el is not None:
            self.motor.el.command(el, t)

    def _advance(self, now: float) -> None:
        """Apply every table step due up to ``now`` at its exact scheduled time."""
        tab = self.table
        period = ((tab.interval_s + self.profile.table_period_extra_s)
                  * self.faults.step_clock_scale) if tab else 0.0
        while tab is not None and tab.running and now >= tab.next_t:
            t = tab.next_t
            tab.index += 1
            self._goto(t, *tab.points[tab.index])
            if tab.index >= len(tab.points) - 1:
                tab.running = False
                if self._end == "clear":
                    self.table = None
                break
            tab.next_t = t + period

    # Command interpreter ----------------------------------------------------------------------

    def handle_line(self, line: bytes, state: _SessionState) -> bytes:
        """One CR-terminated request (without the CR) → the exact reply bytes."""
        with self._lock:
            t = self._now()
            self._advance(t)
            self.commands_seen += 1
            reply = self._dispatch(line, state, t)
            self.log.append((t, line, reply))
            del self.log[:-200]
            return reply

    def _err(self) -> bytes:
        return ERROR_REPLY + b"\r\n"

    def _ack(self, k3ng_text: bytes = b"") -> bytes:
        if self.profile.k3ng_messages and k3ng_text:
            return k3ng_text + b"\r\n"
        return self.profile.set_ack

    def _data(self, payload: bytes) -> bytes:
        return payload + self.profile.reply_eol

    def _dispatch(self, raw: bytes, st: _SessionState, t: float) -> bytes:
        """Decode one line with the drivers' codec and hand the message to its handler."""
        if len(raw) > self.profile.max_line_chars:
            return self._err()
        text = codec.command_text(raw)
        if text is None:
            return self._err()
        if st.calibration is not None:
            return self._calibration_dialogue(text, st)
        msg = codec.decode_command(text, dialect=self.dialect,
                                   az_max_deg=self._wire_az_max(),
                                   el_max_deg=self.el_field_max_deg)
        return self._handle(msg, st, t)

    def _handle(self, msg: codec.Command, st: _SessionState, t: float) -> bytes:
        return self._handlers[type(msg)](msg, st, t)

    def _calibration_dialogue(self, text: str, st: _SessionState) -> bytes:
        """O/O2 wait for Y; F/F2 stream the reading until a blank line."""
        if st.calibration in ("O", "O2"):
            st.calibration = None
            return b"Completed.\r\n" if text == "Y" else self._err()
        if text == "":
            st.calibration = None
            return self._ack()
        return b""

    # Handlers: one per message type of the codec ----------------------------------------------

    def _on_query(self, msg: codec.Query, st: _SessionState, t: float) -> bytes:
        if msg.kind == "B" and self.motor.el is None and self.profile.family == "b":
            return self._err()
        az, el = self._readback(t)
        return self._data(format_position(self.profile, msg.kind, az, el))

    def _on_stop(self, msg: codec.Stop, st: _SessionState, t: float) -> bytes:
        if msg.axis == "all":
            if self.rotator_on:
                self.motor.stop(t)
            self._halt_table()
        elif msg.axis == "az" and self.rotator_on:
            self.motor.az.stop(t)
        elif msg.axis == "el" and self.motor.el is not None and self.rotator_on:
            self.motor.el.stop(t)
        return self._ack()

    def _on_turn(self, msg: codec.Turn, st: _SessionState, t: float) -> bytes:
        if not self.rotator_on:
            return self._ack()
        if msg.direction in ("cw", "ccw"):
            hi = float(min(self._wire_az_max(), self.spec.az_span_deg))
            if self.south_centre and not self.mode_450:
                hi = 360.0
            self.motor.az.command(hi if msg.direction == "cw" else 0.0, t)
        elif self.motor.el is not None:
            self.motor.el.command(self.motor.el.max_deg if msg.direction == "up"
                                  else self.motor.el.min_deg, t)
        if msg.direction == "cw" and self.profile.k3ng_messages:
            return b"\n\r\n"
        return self._ack()

    def _on_speed(self, msg: codec.Speed, st: _SessionState, t: float) -> bytes:
        self.speed_step = msg.step
        self._apply_speed(t)
        return self._ack(b"Speed " + codec.encode(msg))

    def _on_mode_450(self, msg: codec.SetMode450, st: _SessionState, t: float) -> bytes:
        if not self.profile.b_commands:
            return self._err()
        self.mode_450 = msg.enabled
        return self._ack(b"Mode 450 degree" if self.mode_450 else b"Mode 360 degree")

    def _on_toggle_centre(self, msg: codec.ToggleCentre, st: _SessionState,
                          t: float) -> bytes:
        if not self.profile.b_commands:
            return self._err()
        if not self.mode_450:     # ignored in 450 mode (manual)
            self.south_centre = not self.south_centre
        return self._ack(b"S Center" if self.south_centre else b"N Center")

    def _on_calibrate(self, msg: codec.Calibrate, st: _SessionState, t: float) -> bytes:
        st.calibration = msg.command
        return b"are you sure?\r\n"

    def _on_full_scale(self, msg: codec.FullScale, st: _SessionState, t: float) -> bytes:
        st.calibration = msg.command
        st.next_stream_t = t
        return b""

    def _on_help(self, msg: codec.Help, st: _SessionState, t: float) -> bytes:
        if msg.page not in self.profile.help_pages:
            return self._err()
        return help_screen(self.profile.family, msg.page, self.mode_450, self.south_centre)

    def _on_start_table(self, msg: codec.StartTable, st: _SessionState, t: float) -> bytes:
        return self._start_table(t)

    def _on_table_status(self, msg: codec.TableStatus, st: _SessionState, t: float) -> bytes:
        if self.table is None:
            return self._err()
        return self._data(format_table_status(self.profile, self.table.index + 1,
                                              len(self.table.points)))

    def _on_goto(self, msg: codec.Goto, st: _SessionState, t: float) -> bytes:
        """Short-form M/W: stepping stops (K3NG: the list is dropped too)."""
        self._halt_table()
        self._goto(t, msg.az, msg.el)
        return self._ack()

    def _on_table(self, msg: codec.Table, st: _SessionState, t: float) -> bytes:
        """Long-form M/W: a new table (the point counts are the profile's)."""
        p, line = self.profile, msg.line
        lo, hi = ((p.min_table_points, p.max_table_points) if line.kind == "M"
                  else (1, p.max_table_pairs))
        if not lo <= len(line.az) <= hi:
            self.table = None
            return self._err()
        points: list[tuple[int, int | None]] = (
            [(a, None) for a in line.az] if line.el is None
            else list(zip(line.az, line.el, strict=True)))
        if line.kind == "W" and p.k3ng_messages and self.table is not None \
                and not self.table.running:
            # K3NG firmware: long-form W does not clear the list, it appends (docs/protocols.md,
            # K3NG), so a 20-pair table arrives as several <= 50-char lines.
            points = self.table.points + points
            if len(points) > p.max_table_pairs:
                self.table = None
                return self._err()
        self.table = _Table(interval_s=line.interval_s, points=points)
        self._goto(t, *points[0])
        return self._ack()

    def _on_bad_table(self, msg: codec.BadTable, st: _SessionState, t: float) -> bytes:
        self.table = None               # manual: "?>" returned, memories still cleared
        return self._err()

    def _on_invalid(self, msg: Any, st: _SessionState, t: float) -> bytes:
        return self._err()

    def _halt_table(self) -> None:
        if self.table:
            self.table.running = False
            if self.profile.k3ng_messages:
                self.table = None

    def _start_table(self, t: float) -> bytes:
        tab = self.table
        if tab is None:
            return self._err()
        tab.index = min(1, len(tab.points) - 1)
        self._goto(t, *tab.points[tab.index])
        tab.running = tab.index < len(tab.points) - 1
        tab.next_t = t + ((tab.interval_s + self.profile.table_period_extra_s)
                          * self.faults.step_clock_scale)
        if not tab.running and self._end == "clear":
            self.table = None
        return self._ack()

    def poll(self, state: _SessionState) -> bytes:
        """Unsolicited output due now (F/F2 calibration streams the reading)."""
        with self._lock:
            t = self._now()
            self._advance(t)
            if state.calibration not in ("F", "F2") or t < state.next_stream_t:
                return b""
            state.next_stream_t = t + FULL_SCALE_INTERVAL_S
            az, el = self._readback(t)
            if state.calibration == "F":
                return b"AZ=%03d\r\n" % az
            return b"AZ=%03dEL=%03d\r\n" % (az, el)


class Session:
    """One connection to the controller: its own line buffer and dialogue state."""

    applies_faults = True     # runs the fault injector itself (servers need not)

    def __init__(self, controller: Gs232Controller):
        self.controller = controller
        opts = controller.options
        if controller.profile.lf_is_command:
            self._framer = LineFramer(b"\r\n", max_line=opts.max_line)
        else:
            # Real GS-232B: LF is not a terminator and is ignored (docs/protocols.md).
            self._framer = LineFramer(b"\r", ignore=b"\n", max_line=opts.max_line)
        self.state = _SessionState(connected=not opts.autobaud)
        self._epoch = controller.power_epoch

    def feed(self, data: bytes) -> bytes:
        """Bytes from the client → reply bytes (possibly empty)."""
        ctrl = self.controller
        if ctrl.faults.deaf:
            return b""
        inj = ctrl.faults.injector
        if inj is not None:
            data = inj.on_input(data)
        if self._epoch != ctrl.power_epoch:     # power-cycled: line buffer and autobaud reset
            self._epoch = ctrl.power_epoch
            self._framer.clear()
            self.state = _SessionState(connected=not ctrl.options.autobaud)
        out = bytearray()
        try:
            lines = self._framer.feed(data)
        except ProtocolError:
            # Input overrun (no CR for max_line bytes): a real unit discards the line and
            # goes on; the emulator must never die on input.
            lines = []
            if self.state.connected:
                out += ERROR_REPLY + b"\r\n"
        for line in lines:
            if not self.state.connected:
                if line == b"":
                    self.state.crs_seen += 1
                    if self.state.crs_seen >= ctrl.options.autobaud_crs:
                        self.state.connected = True
                        out += b"Connect OK\r\n"
                continue
            out += ctrl.handle_line(line, self.state)
        return self._filter(bytes(out))

    def poll(self) -> bytes:
        out = self._filter(self.controller.poll(self.state))
        inj = self.controller.faults.injector
        return out + inj.release(self) if inj is not None else out

    def next_output_in_s(self) -> float | None:
        """Controller seconds until this session has unsolicited output (F/F2 streaming)."""
        if self.state.calibration not in ("F", "F2"):
            return None
        return max(0.0, self.state.next_stream_t - self.controller.clock.monotonic())

    def _filter(self, reply: bytes) -> bytes:
        f = self.controller.faults
        if f.silent or not reply:
            return b""
        reply = f.reply_filter(reply) if f.reply_filter else reply
        return f.injector.on_output(self, reply) if f.injector is not None else reply


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw: Any) -> Gs232Controller:
    """The registry's emulator factory: ``protocol`` is the dialect (a profile name)."""
    return Gs232Controller(protocol, spec, clock, **kw)
