"""Virtual GS-232B-AZ/AZ dual-azimuth controller (VE2DX proposal v2.0.0;
docs/protocols.md).

Built on :class:`Gs232Controller`: azimuth 2 *is* the GS-232B elevation channel (the
proposal reuses command set 2 for it), so it lives in the motor model's second axis with
azimuth limits 0-360, and ``C2`` answers ``AZ=aaaEL=bbb`` (no space, as the proposal
writes it), ``B`` answers ``EL=bbb``, ``U``/``D``/``E`` turn CW / CCW / stop azimuth 2,
``Wxxx yyy`` sets both, ``S`` stops both. Added: ``MBxxx`` (azimuth 2 to 000-360),
``XBn`` (azimuth 2 speed), ``ZB``/``P36B``/``P45B`` (accepted, stored), the timed
``MBsss aaa bbb ...`` / ``TB`` / ``NB`` for azimuth 2 (same rules as M / T / N), ``Y``
(sync azimuth 2 to azimuth 1), ``Ynnn`` (sync with azimuth 2 = azimuth 1 + nnn mod 360, from
azimuth 1's real-time position) and ``Y999`` (cancel; a power cycle cancels too).

Choices where the proposal is silent or ambiguous: set commands, Y included, are silent like a
real GS-232B (``?>`` for invalid ones); while synced every command-set-3 command (U, D, E,
MB, XB, ZB, P36B, P45B, TB, NB) is ignored silently, as the proposal says, but ``B`` and
``C2`` still answer; synced azimuth-1 commands (M, W, R, L, A, X, tables) drive azimuth 2 to
azimuth 1's target + offset, and W's second value is ignored; ``S`` stops both
(``s_stops`` = "az1" / "az2" makes it configurable, as the proposal suggests). The
calibration commands ``O2B``/``FB``/``FB2`` are not emulated and answer ``?>`` (the proposal
maps them to O2/F/F2 without saying how they differ from the elevation channel's own ``O2``
and ``F2``, which calibrate azimuth 2 here).
"""

from __future__ import annotations

from typing import Literal

from tracker.clock import Clock
from tracker.emulator.gs232_controller import (
    EmulatorOptions,
    Gs232Controller,
    _SessionState,
    _Table,
)
from tracker.mount import PRESETS, AxisMotor, RotatorSpec
from tracker.protocols import gs232_codec as codec
from tracker.protocols.azaz import AZAZ_PROFILE
from tracker.protocols.gs232 import format_table_status

AZ_360 = PRESETS["AZ-360"]
# Command set 3 (azimuth 2), which the interface ignores while the antennas are synced.
SET3 = (codec.GotoB, codec.TableB, codec.BadTableB, codec.SpeedB, codec.ToggleCentreB,
        codec.SetMode450B, codec.StartTableB, codec.TableStatusB, codec.InvalidB)


def _is_set3(msg: codec.Command) -> bool:
    """``U``/``D``/``E`` are the elevation commands, which drive azimuth 2 here."""
    return (isinstance(msg, SET3)
            or (isinstance(msg, codec.Turn) and msg.direction in ("up", "down"))
            or (isinstance(msg, codec.Stop) and msg.axis == "el"))


class AzAzController(Gs232Controller):
    el_field_max_deg = 360            # the second field of W is azimuth 2
    dialect: codec.Dialect = "azaz"

    def __init__(self, spec: RotatorSpec | None = None, spec2: RotatorSpec | None = None,
                 clock: Clock | None = None, options: EmulatorOptions | None = None,
                 az_deg: float | None = None, az2_deg: float | None = None,
                 s_stops: Literal["both", "az1", "az2"] = "both"):
        spec = (spec or AZ_360).with_(el_max_deg=None, el_rate_deg_s=None)
        spec2 = spec2 or spec
        super().__init__(AZAZ_PROFILE, spec, clock, options, az_deg=az_deg)
        self.spec2 = spec2
        self.motor.el = AxisMotor(0.0, min(360.0, spec2.az_span_deg), spec2.az_rate_deg_s,
                                  spec2.start_delay_s, spec2.resolution_deg,
                                  spec2.park_az_deg if az2_deg is None else az2_deg,
                                  self.clock.monotonic())
        self.sync_offset: int | None = None
        self.s_stops = s_stops
        self.speed_step_b = 4
        self.flags_b = {"P45B": False, "ZB": False}
        self.table_b: _Table | None = None
        self._handlers |= {
            codec.Sync: self._on_sync, codec.Unsync: self._on_unsync,
            codec.GotoB: self._on_goto_b, codec.TableB: self._on_table_b,
            codec.BadTableB: self._on_bad_table_b, codec.SpeedB: self._on_speed_b,
            codec.ToggleCentreB: self._on_toggle_centre_b,
            codec.SetMode450B: self._on_mode_450_b, codec.StartTableB: self._on_start_table_b,
            codec.TableStatusB: self._on_table_status_b, codec.InvalidB: self._on_invalid,
        }

    def power_cycle(self, reset_sessions: bool = False) -> None:
        with self._lock:
            super().power_cycle(reset_sessions)
            self.sync_offset = None
            self.table_b = None
            self.speed_step_b = 4

    # Azimuth 2 follows azimuth 1 while synced -------------------------------------------------

    def _follow(self, az: float) -> int:
        return round(az + (self.sync_offset or 0)) % 360

    def _goto(self, t: float, az: int | None, el: int | None) -> None:
        if self.sync_offset is not None and az is not None:
            el = self._follow(self._mech_of_wire(az))
        super()._goto(t, az, el)

    def _with_table_b(self, fn):
        saved, self.table = self.table, self.table_b
        try:
            return fn()
        finally:
            self.table_b, self.table = self.table, saved

    def _advance(self, now: float) -> None:
        super()._advance(now)
        if getattr(self, "table_b", None) is not None:
            self._with_table_b(lambda: Gs232Controller._advance(self, now))

    # Handlers: the GS-232B ones, with azimuth 2 on command set 3 -----------------------------

    def _handle(self, msg: codec.Command, st: _SessionState, t: float) -> bytes:
        if self.sync_offset is not None and _is_set3(msg):
            return self._ack()                       # ignored while synced (proposal)
        return super()._handle(msg, st, t)

    def _on_stop(self, msg: codec.Stop, st: _SessionState, t: float) -> bytes:
        all_stop = msg.axis == "all" and self.s_stops == "both"
        if msg.axis == "all" and not all_stop:
            msg = codec.Stop("az" if self.s_stops == "az1" else "el")
        reply = super()._on_stop(msg, st, t)
        if all_stop and self.table_b:
            self.table_b.running = False
        if self.sync_offset is not None and msg.axis == "az":
            self.motor.el.stop(t)
        return reply

    def _on_turn(self, msg: codec.Turn, st: _SessionState, t: float) -> bytes:
        reply = super()._on_turn(msg, st, t)
        az2 = self.motor.el
        if self.sync_offset is not None and msg.direction in ("cw", "ccw"):
            az2.command(az2.max_deg if msg.direction == "cw" else az2.min_deg, t)
        return reply

    def _on_speed(self, msg: codec.Speed, st: _SessionState, t: float) -> bytes:
        reply = super()._on_speed(msg, st, t)
        if self.sync_offset is not None:
            self._set_rate_b(msg.step, t)
        return reply

    def _set_rate_b(self, step: int, t: float) -> None:
        rates = self.spec2.az_speed_rates_deg_s
        if rates:
            self.motor.el.set_rate(rates[min(step, len(rates)) - 1], t)

    def _on_sync(self, msg: codec.Sync, st: _SessionState, t: float) -> bytes:
        self.sync_offset = msg.offset_deg % 360
        self.motor.el.command(self._follow(self.motor.az.position(t)), t)
        if self.table_b:
            self.table_b.running = False
        return self._ack()

    def _on_unsync(self, msg: codec.Unsync, st: _SessionState, t: float) -> bytes:
        self.sync_offset = None
        return self._ack()

    def _on_goto_b(self, msg: codec.GotoB, st: _SessionState, t: float) -> bytes:
        if self.table_b:
            self.table_b.running = False
        self.motor.el.command(msg.az, t)
        return self._ack()

    def _on_table_b(self, msg: codec.TableB, st: _SessionState, t: float) -> bytes:
        p, angles = self.profile, msg.line.az
        if not p.min_table_points <= len(angles) <= p.max_table_points:
            self.table_b = None
            return self._err()
        self.table_b = _Table(interval_s=msg.line.interval_s,
                              points=[(None, a) for a in angles])
        self.motor.el.command(angles[0], t)
        return self._ack()

    def _on_bad_table_b(self, msg: codec.BadTableB, st: _SessionState, t: float) -> bytes:
        self.table_b = None
        return self._err()

    def _on_speed_b(self, msg: codec.SpeedB, st: _SessionState, t: float) -> bytes:
        self.speed_step_b = msg.step
        self._set_rate_b(msg.step, t)
        return self._ack()

    def _on_toggle_centre_b(self, msg: codec.ToggleCentreB, st: _SessionState,
                            t: float) -> bytes:
        self.flags_b["ZB"] = not self.flags_b["ZB"]
        return self._ack()

    def _on_mode_450_b(self, msg: codec.SetMode450B, st: _SessionState, t: float) -> bytes:
        self.flags_b["P45B"] = msg.enabled
        return self._ack()

    def _on_start_table_b(self, msg: codec.StartTableB, st: _SessionState, t: float) -> bytes:
        return self._with_table_b(lambda: self._start_table(t))

    def _on_table_status_b(self, msg: codec.TableStatusB, st: _SessionState,
                           t: float) -> bytes:
        if self.table_b is None:
            return self._err()
        return self._data(format_table_status(self.profile, self.table_b.index + 1,
                                              len(self.table_b.points)))

    def antenna(self) -> tuple[float, float]:
        """(azimuth 1, azimuth 2) of the simulated antennas now."""
        az, az2 = super().antenna()
        return az, float(az2 if az2 is not None else 0.0)

    def status_line(self) -> str:
        a1, a2 = self.antenna()
        sync = "" if self.sync_offset is None else f"  synced +{self.sync_offset:03d}"
        state = "moving" if self.moving() else "idle"
        return (f"{self.profile.name}  az1 {a1:6.1f}  az2 {a2:6.1f}  X{self.speed_step}/"
                f"XB{self.speed_step_b}  {state}{sync}  cmds {self.commands_seen}")


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw) -> AzAzController:
    """The registry's emulator factory: one box for both antennas' protocol names
    (``spec2`` in ``kw``: antenna 2's rotator, default the same as antenna 1's)."""
    return AzAzController(spec, kw.pop("spec2", None), clock, **kw)
