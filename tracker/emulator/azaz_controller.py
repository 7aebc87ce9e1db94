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
from tracker.protocols.azaz import AZAZ_PROFILE
from tracker.protocols.gs232 import format_table_status
from tracker.protocols.gs232_tables import decode_table_line

AZ_360 = PRESETS["AZ-360"]
SET3 = ("U", "D", "E", "ZB", "P36B", "P45B", "TB", "NB", "O2B", "FB", "FB2")


class AzAzController(Gs232Controller):
    el_field_max_deg = 360            # the second field of W is azimuth 2

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

    # Interpreter -----------------------------------------------------------------------------

    # Protocol dispatch: one branch per command of the wire protocol.
    def _dispatch(self, raw: bytes, st: _SessionState, t: float) -> bytes:  # noqa: C901
        try:
            line = raw.decode("ascii").strip().upper()
        except UnicodeDecodeError:
            return self._err()
        if st.calibration is not None or not line:
            return super()._dispatch(raw, st, t)
        az2 = self.motor.el
        if line[0] == "Y" and (line == "Y" or (line[1:].isdigit() and len(line) == 4)):
            n = 0 if line == "Y" else int(line[1:])
            if n == 999:
                self.sync_offset = None
                return self._ack()
            if n > 360:
                return self._err()
            self.sync_offset = n % 360
            az2.command(self._follow(self.motor.az.position(t)), t)
            if self.table_b:
                self.table_b.running = False
            return self._ack()
        is_set3 = line in SET3 or line.startswith(("MB", "XB"))
        if is_set3 and self.sync_offset is not None:
            return self._ack()                       # ignored while synced (proposal)
        if line.startswith("MB"):
            return self._mb(line[2:].split(), t)
        if line.startswith("XB") and line[2:] in ("1", "2", "3", "4"):
            self.speed_step_b = int(line[2])
            rates = self.spec2.az_speed_rates_deg_s
            if rates:
                az2.set_rate(rates[min(self.speed_step_b, len(rates)) - 1], t)
            return self._ack()
        if line in ("ZB", "P36B", "P45B"):
            key = "ZB" if line == "ZB" else "P45B"
            self.flags_b[key] = (not self.flags_b["ZB"]) if line == "ZB" else line == "P45B"
            return self._ack()
        if line == "TB":
            return self._with_table_b(lambda: self._start_table(t))
        if line == "NB":
            if self.table_b is None:
                return self._err()
            return self._data(format_table_status(self.profile, self.table_b.index + 1,
                                                  len(self.table_b.points)))
        if line == "S" and self.s_stops != "both":
            line = "A" if self.s_stops == "az1" else "E"
            raw = line.encode()
        reply = super()._dispatch(raw, st, t)
        if line == "S" and self.table_b:
            self.table_b.running = False
        if self.sync_offset is not None:
            if line in ("R", "L"):
                az2.command(az2.max_deg if line == "R" else az2.min_deg, t)
            elif line == "A":
                az2.stop(t)
            elif line[:1] == "X" and line[1:] in ("1", "2", "3", "4"):
                rates = self.spec2.az_speed_rates_deg_s
                if rates:
                    az2.set_rate(rates[min(int(line[1]), len(rates)) - 1], t)
        return reply

    def _mb(self, args: list[str], t: float) -> bytes:
        if len(args) == 1:
            v = self._parse_ints(args, 0, 360)
            if v is None or len(args[0]) != 3:
                return self._err()
            if self.table_b:
                self.table_b.running = False
            self.motor.el.command(v[0], t)
            return self._ack()
        try:   # MBsss aaa ... is the long-form M line of antenna 2: the shared codec
            decoded = decode_table_line("M" + " ".join(args), strict=False, az_max_deg=360)
        except ValueError:
            decoded = None
        p = self.profile
        if decoded is None or not (p.min_table_points <= len(decoded.az) <= p.max_table_points):
            self.table_b = None
            return self._err()
        angles = decoded.az
        self.table_b = _Table(interval_s=decoded.interval_s, points=[(None, a) for a in angles])
        self.motor.el.command(angles[0], t)
        return self._ack()

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
