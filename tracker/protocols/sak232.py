"""Zelpro SAK-232 driver (Zelpro's Quick User's Guide; docs/protocols.md).

9600 8N1, no handshake; commands are one capital letter, space-separated parameters and
CR: ``A aaa`` (0-359, no padding), ``R ±ddd``, ``O aaa``, ``K``, ``P pp ddd``, ``S``. The
guide documents no reply and no query, so the driver never waits for one and runs open loop:
``position()`` is the motor-model estimate (:class:`tracker.protocols.rotorez.OpenLoopAz`)
and ``capabilities.has_position_query`` is False. ``orient(az)`` (``O``) both tells the
controller and re-anchors the estimate, which is how to calibrate it. The commands are one
codec both ways (:func:`encode`, :func:`decode_command`): the driver encodes them, the emulator
decodes them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from tracker.clock import Clock
from tracker.errors import LimitError
from tracker.mount import RotatorSpec
from tracker.protocols.base import Capabilities, Direction
from tracker.protocols.link import ByteLink, LinkDriver, driver_on_port
from tracker.protocols.rotorez import open_loop_estimate
from tracker.transport import Port

BAUDRATE = 9600


def encode_azimuth(az_deg: float) -> int:
    """Rounded 0..359; 359.5..360 wraps to 0. Outside 0..360 raises :class:`LimitError`."""
    try:
        v = float(az_deg)
    except (TypeError, ValueError) as e:
        raise LimitError(f"azimuth {az_deg!r} is not a number") from e
    if not 0.0 <= v <= 360.0:
        raise LimitError(f"azimuth {az_deg!r} deg is outside 0..359 deg; nothing was sent")
    return round(v) % 360


def gear_ok(pulses: int, degrees: int) -> bool:
    """The guide's rule: 1-999 pulses, 1-24 degrees, 1 to 24 pulses per degree."""
    return (1 <= pulses <= 999 and 1 <= degrees <= 24 and degrees <= pulses
            and pulses <= 24 * degrees)


def check_gear(pulses: int, degrees: int) -> None:
    """:func:`gear_ok`, raising :class:`LimitError` (nothing is sent)."""
    if not gear_ok(pulses, degrees):
        raise LimitError(f"gear ratio {pulses} pulses / {degrees} deg is invalid; allowed "
                         f"1-999 pulses, 1-24 degrees, 1..24 pulses per degree")


# Codec: commands both ways (the driver encodes, the emulator decodes) -------------------------


@dataclass(frozen=True)
class GotoAz:
    """``A aaa``: turn to azimuth 0-359."""
    az: int


@dataclass(frozen=True)
class MoveRelative:
    """``R ±ddd``: turn by ``delta_deg``, clipped to the limits."""
    delta_deg: int


@dataclass(frozen=True)
class Orient:
    """``O aaa``: the antenna points at ``az`` now."""
    az: int


@dataclass(frozen=True)
class FindLimits:
    """``K``: run to both hard limits and store them."""


@dataclass(frozen=True)
class SetGear:
    """``P pp ddd``: ``pulses`` per ``degrees`` (:func:`gear_ok`)."""
    pulses: int
    degrees: int


@dataclass(frozen=True)
class Stop:
    """``S``."""


@dataclass(frozen=True)
class Gs23Goto:
    """``Maaa`` (0-359, three digits): the GS-23 subset LOGGER sends."""
    az: int


@dataclass(frozen=True)
class Gs23Position:
    """``C``: the GS-23 subset's position query."""


@dataclass(frozen=True)
class Invalid:
    """Anything else: a lower-case letter, a missing or out-of-range number."""
    text: bytes


Command = (GotoAz | MoveRelative | Orient | FindLimits | SetGear | Stop | Gs23Goto
           | Gs23Position | Invalid)


def encode(msg: Command) -> bytes:
    """The command line for ``msg``, without the CR."""
    if isinstance(msg, GotoAz):
        text = f"A {msg.az}"
    elif isinstance(msg, MoveRelative):
        text = f"R {msg.delta_deg}"
    elif isinstance(msg, Orient):
        text = f"O {msg.az}"
    elif isinstance(msg, SetGear):
        text = f"P {msg.pulses} {msg.degrees}"
    elif isinstance(msg, (FindLimits, Stop, Gs23Position)):
        text = next(head for head, bare in _BARE.items() if bare == msg)
    elif isinstance(msg, Gs23Goto):
        text = f"M{msg.az:03d}"
    else:
        raise ValueError(f"{msg!r} is not a command a host sends")
    return text.encode("ascii")


_BARE: dict[str, Command] = {"S": Stop(), "K": FindLimits(), "C": Gs23Position()}


def _one_azimuth(nums: list[int]) -> int | None:
    return nums[0] if len(nums) == 1 and 0 <= nums[0] <= 359 else None


def decode_command(line: bytes) -> Command:
    """One line (without the ENTER) as the controller reads it: case-sensitive, parameters
    separated by blanks, decimal numbers (no zero padding needed)."""
    try:
        parts = line.decode("ascii").split()
        head, nums = parts[0], [int(a, 10) for a in parts[1:]]
    except (UnicodeDecodeError, IndexError, ValueError):
        return Invalid(line)
    az = _one_azimuth(nums)
    if head in _BARE and not nums:
        return _BARE[head]
    if head in ("A", "O") and az is not None:
        return GotoAz(az) if head == "A" else Orient(az)
    if head == "R" and len(nums) == 1 and abs(nums[0]) <= 999:
        return MoveRelative(nums[0])
    if head == "P" and len(nums) == 2 and gear_ok(*nums):
        return SetGear(*nums)
    if (head.startswith("M") and not nums and head[1:].isdigit() and len(head) == 4
            and int(head[1:]) <= 359):
        return Gs23Goto(int(head[1:]))
    return Invalid(line)


class Sak232Driver(LinkDriver):

    raw_terminator = b"\r"
    def __init__(self, port: Port, *, timeout_s: float = 1.0, pace_cmd_s: float = 0.05,
                 clock: Clock | None = None, rate_deg_s: float = 4.0,
                 start_az_deg: float = 0.0, start_delay_s: float = 0.2,
                 stop_bearing_deg: float = 0.0, spec: RotatorSpec | None = None,
                 has_elevation: bool | None = None,
                 az_max_deg: float | None = None, el_max_deg: float | None = None,
                 autobaud: bool = False):
        # has_elevation / az_max_deg / el_max_deg / autobaud are what generic callers pass
        # to every driver; the SAK-232 is azimuth-only 0-359 and has no autobaud.
        self.link = ByteLink(port, clock, pace_cmd_s)
        self.clock = self.link.clock
        self.timeout_s = float(timeout_s)
        self.capabilities = Capabilities(
            has_elevation=False, has_position_query=False, has_axis_stop=False,
            has_manual_move=False, has_speed=False, speed_steps=0, az_max_deg=359.0,
            el_max_deg=0.0)
        self.estimate = open_loop_estimate(self.clock, spec, rate_deg_s, start_delay_s,
                                           start_az_deg, stop_bearing_deg)
        self.stop_on_exit = True

    @classmethod
    def from_url(cls, url: str, *, baudrate: int | None = None, **kw: Any) -> Sak232Driver:
        return driver_on_port(cls, url, port_kw=dict(
            baudrate=baudrate or BAUDRATE, timeout_s=0.05, clock=kw.get("clock")), **kw)

    def _send(self, msg: Command) -> None:
        with self.link.lock:
            self.link.write(encode(msg) + b"\r")

    def position(self) -> tuple[float, float | None]:
        """The motor-model estimate: the SAK-232 has no position query."""
        return round(self.estimate.position(), 1), None

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        az = encode_azimuth(az_deg)
        self._send(GotoAz(az))
        self.estimate.command(float(az))

    def move_relative(self, delta_deg: float) -> None:
        """``R ±ddd``: the controller clips the move to its limits."""
        d = round(float(delta_deg))
        if not -359 <= d <= 359:
            raise LimitError(f"relative move {delta_deg!r} deg is invalid; allowed -359..359")
        self._send(MoveRelative(d))
        self.estimate.command_relative(d)      # the motor model clamps to the span

    def orient(self, az_deg: float) -> None:
        """``O aaa``: the antenna is known to point at ``az_deg`` now."""
        az = encode_azimuth(az_deg)
        self._send(Orient(az))
        self.estimate.set(float(az))

    def find_limits(self) -> None:
        """``K``: the controller runs to both hard limits (needs limit switches)."""
        self._send(FindLimits())

    def set_gear(self, pulses: int, degrees: int) -> None:
        check_gear(int(pulses), int(degrees))
        self._send(SetGear(int(pulses), int(degrees)))

    def stop(self) -> None:
        self._send(Stop())
        self.estimate.stop()

    def move(self, direction: Direction) -> None:
        raise LimitError("the SAK-232 has no manual-move command; use goto or move_relative")



def open_sak232(protocol: str, url: str, **kw: Any) -> Sak232Driver:
    """The registry's driver factory."""
    return Sak232Driver.from_url(url, **kw)
