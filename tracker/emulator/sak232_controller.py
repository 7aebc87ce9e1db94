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

from dataclasses import dataclass

from tracker.clock import Clock
from tracker.emulator.rotorez_controller import ByteController, SessionState
from tracker.mount import PRESETS, RotatorSpec

ZELPRO_RAU = PRESETS["Zelpro-RAU"]


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

    # Protocol dispatch: one branch per command of the wire protocol.
    def _command(self, raw: bytes) -> bytes:  # noqa: C901
        t = self._now()
        self._advance(t)
        o = self.options
        try:
            parts = raw.decode("ascii").split()
        except UnicodeDecodeError:
            return o.error
        if not parts:
            return o.error
        head, args = parts[0], parts[1:]
        nums: list[int] = []
        for a in args:
            try:
                nums.append(int(a, 10))
            except ValueError:
                return o.error
        az = self.motor.az
        if head == "S" and not nums:
            self.k_phase = 0
            az.stop(t)
            return o.ack
        if head == "A" and len(nums) == 1 and 0 <= nums[0] <= 359:
            self.k_phase = 0
            az.command(self._clip(self._mech_near(nums[0])), t)
            return o.ack
        if head == "R" and len(nums) == 1 and abs(nums[0]) <= 999:
            self.k_phase = 0
            az.command(self._clip(az.position(t) + nums[0]), t)
            return o.ack
        if head == "O" and len(nums) == 1 and 0 <= nums[0] <= 359:
            self.offset_deg = (nums[0] - az.position(t)) % 360.0
            return o.ack
        if head == "K" and not nums:
            az.command(az.min_deg, t)
            self.k_phase = 1
            self._advance(t)
            return o.ack
        if head == "P" and len(nums) == 2:
            pp, ddd = nums
            if 1 <= pp <= 999 and 1 <= ddd <= 24 and ddd <= pp and pp <= 24 * ddd:
                self.gear = (pp, ddd)
                az.stop(t)
                az.resolution_deg = ddd / pp
                return o.ack
            return o.error
        if o.gs23:
            if head.startswith("M") and not nums and head[1:].isdigit() and len(head) == 4 \
                    and int(head[1:]) <= 359:
                az.command(self._clip(self._mech_near(int(head[1:]))), t)
                return o.ack
            if head == "C" and not nums:
                return b"+0%03d\r\n" % self.readback()
        return o.error

    def status_line(self) -> str:
        k = {0: "", 1: "  K: seeking CCW limit", 2: "  K: seeking CW limit"}[self.k_phase]
        return (f"{super().status_line()}  gear {self.gear[0]}/{self.gear[1]}  "
                f"offset {self.offset_deg:.0f}{k}")


def emulate(protocol: str, clock: Clock, spec: RotatorSpec, **kw) -> Sak232Controller:
    """The registry's emulator factory."""
    return Sak232Controller(spec, clock, **kw)
