"""Idiom Press Rotor-EZ / RotorCard and Hy-Gain DCU-1: driver, codec and shared byte I/O.

Wire facts (docs/protocols.md): 4800 8N1, letters case-sensitive, bearings three
zero-padded digits. ``AP1ddd\\r`` sets and goes; ``AP1ddd;`` only sets and ``AM1;`` executes
it; ``AI1;`` answers exactly ``;ddd`` with no terminator; ``;`` stops (Rotor-EZ), ``AS1;``
stops (DCU-1). Single bytes ``E e O o S s J j`` switch options, ``V`` asks the version. A real
V1.4S answers ``;`` while idle with the banner ``C2000 IDIOM V1.4S `` and sends a stray byte
(0xE0) at power-on, so replies are found by searching for ``;ddd`` in whatever arrived, never
by position in the stream.

The DCU-1 has no position query: :class:`OpenLoopAz` keeps the motor model's estimate of
where the antenna is, and ``capabilities.has_position_query`` is False so callers know the
position is an estimate.

The commands are one codec both ways (:func:`encode`, :func:`decode_command`,
:func:`decode_single`; the ``AI1;`` reply :func:`format_ai_reply` / :func:`parse_ai_reply`):
the driver encodes, the emulator decodes.

Also home of :class:`OpenLoopAz`, used by the SAK-232, AZ/AZ and rotctld drivers too. The
byte I/O (:class:`ByteLink`) is :mod:`tracker.protocols.link`'s, shared by every driver.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Literal

from tracker.clock import Clock
from tracker.errors import ConfigError, LimitError, RotatorTimeout
from tracker.mount import AxisMotor, RotatorSpec
from tracker.protocols.base import Capabilities, Direction
from tracker.protocols.link import ByteLink, LinkDriver, driver_on_port
from tracker.transport import Port

BAUDRATE = 4800
BANNER = b"C2000 IDIOM V1.4S "
OPTION_BYTES = {"endpoint": (b"E", b"e"), "overshoot": (b"O", b"o"),
                "unstick": (b"S", b"s"), "jam": (b"J", b"j")}
_AI_RE = re.compile(rb";(\d{3})")
_AI_OLD_RE = re.compile(rb"(?<![\d;])(\d{3});")   # old ERC / "DCU-1 Plus": ddd;


class OpenLoopAz:
    """Where an azimuth rotator without a position query should be, from what was sent.

    The same :class:`tracker.mount.AxisMotor` the planner and emulator use, advanced on the
    driver's clock, in the mechanical frame of a rotator whose end stop is at
    ``stop_bearing_deg`` (so a move takes the way the real rotator must take); positions in
    and out are the controller's bearings. The estimate starts at ``start_az_deg`` (assumed,
    not measured): calibrate (park against a stop, SAK-232 ``O``) before trusting it.
    """

    def __init__(self, clock: Clock, rate_deg_s: float = 6.0, start_delay_s: float = 0.5,
                 start_az_deg: float = 0.0, stop_bearing_deg: float = 0.0,
                 span_deg: float = 359.0):
        self.clock = clock
        self.stop_bearing_deg = float(stop_bearing_deg)
        self.motor = AxisMotor(0.0, span_deg, rate_deg_s, start_delay_s, 1.0,
                               self._mech(start_az_deg), clock.monotonic())

    def _mech(self, bearing: float) -> float:
        return (float(bearing) - self.stop_bearing_deg) % 360.0

    def command(self, az_deg: float) -> None:
        self.motor.command(self._mech(az_deg), self.clock.monotonic())

    def command_relative(self, delta_deg: float) -> None:
        self.motor.command(self.motor.target_deg + float(delta_deg), self.clock.monotonic())

    def stop(self) -> None:
        self.motor.stop(self.clock.monotonic())

    def set(self, az_deg: float) -> None:
        """The antenna is known to be at ``az_deg`` now (calibration)."""
        m = self.motor
        self.motor = AxisMotor(m.min_deg, m.max_deg, m.rate_deg_s, m.start_delay_s, 1.0,
                               self._mech(az_deg), self.clock.monotonic())

    def position(self) -> float:
        m = float(self.motor.position(self.clock.monotonic()))
        return (m + self.stop_bearing_deg) % 360.0

    def moving(self) -> bool:
        return self.motor.moving(self.clock.monotonic())


def open_loop_estimate(clock: Clock, spec: RotatorSpec | None, rate_deg_s: float,
                       start_delay_s: float, start_az_deg: float,
                       stop_bearing_deg: float) -> OpenLoopAz:
    """The estimate from ``spec`` when given (its rate, start delay, stop bearing, and the
    park position as the assumed start), else from the explicit values."""
    if spec is None:
        return OpenLoopAz(clock, rate_deg_s, start_delay_s, start_az_deg, stop_bearing_deg)
    # The wire carries true bearings only when the controller maps them (docs/architecture.md);
    # otherwise it carries mechanical degrees, whose "stop bearing" is 0.
    frame = spec.frame
    park = frame.wire_of(float(spec.park_az_deg))
    stop = frame.stop_bearing_deg if frame.wire_takes_bearing else 0.0
    return OpenLoopAz(clock, spec.az_rate_deg_s, spec.start_delay_s, park, stop,
                      min(spec.az_span_deg, 359.0))


def encode_bearing(az_deg: float, max_deg: float = 360.0) -> bytes:
    """Three digits, rounded half-to-even like Hamlib; 359.5..360 wraps to ``000`` (Hamlib:
    "for DCU-1 compatibility"). Outside 0..``max_deg`` raises :class:`LimitError`."""
    try:
        v = float(az_deg)
    except (TypeError, ValueError) as e:
        raise LimitError(f"azimuth {az_deg!r} is not a number") from e
    if not (0.0 <= v <= max_deg):
        raise LimitError(f"azimuth {az_deg!r} deg is outside the controller range "
                         f"0..{max_deg:g} deg; nothing was sent")
    n = round(v)
    return b"%03d" % (0 if n >= 360 else n)


def parse_ai_reply(buf: bytes, accept_old: bool = False) -> int | None:
    """The bearing in an ``AI1;`` reply found anywhere in ``buf`` (banner and stray bytes
    around it are ignored), or None. ``accept_old`` also takes the old ERC ``ddd;``."""
    m = _AI_RE.search(buf)
    if m:
        return int(m.group(1))
    if accept_old:
        m = _AI_OLD_RE.search(buf)
        if m:
            return int(m.group(1))
    return None


def format_ai_reply(bearing: int) -> bytes:
    """The controller's answer to ``AI1;``: ``;ddd``, no terminator."""
    return b";%03d" % bearing


# Codec: commands both ways (the driver encodes, the emulator decodes) -------------------------


@dataclass(frozen=True)
class SetBearing:
    """``AP1ddd\\r`` (``go``: set and turn, Rotor-EZ) or ``AP1ddd;`` (set only)."""
    bearing: int
    go: bool


@dataclass(frozen=True)
class Execute:
    """``AM1;``: turn to the bearing set last."""


@dataclass(frozen=True)
class QueryBearing:
    """``AI1;``: answered ``;ddd`` (Rotor-EZ)."""


@dataclass(frozen=True)
class Stop:
    """``;`` on its own (Rotor-EZ)."""


@dataclass(frozen=True)
class StopAxis:
    """``AS1;`` (DCU-1)."""


@dataclass(frozen=True)
class SetOption:
    """One option byte (:data:`OPTION_BYTES`): upper case switches ``name`` on."""
    name: str
    enabled: bool


@dataclass(frozen=True)
class Version:
    """``V``."""


@dataclass(frozen=True)
class Invalid:
    """A terminated command no controller of the family takes."""
    text: bytes


Command = (SetBearing | Execute | QueryBearing | Stop | StopAxis | SetOption | Version
           | Invalid)

_TERMINATED: dict[bytes, Command] = {b"AM1;": Execute(), b"AI1;": QueryBearing(),
                                     b"AS1;": StopAxis()}
_SINGLE: dict[bytes, Command] = {
    b";": Stop(), b"V": Version(),
    **{byte: SetOption(name, byte.isupper())
       for name, pair in OPTION_BYTES.items() for byte in pair}}
_TEXT: dict[Command, bytes] = {msg: text for text, msg in (_TERMINATED | _SINGLE).items()}


def encode(msg: Command) -> bytes:
    """The bytes of ``msg``, terminator included (single-byte commands have none)."""
    if isinstance(msg, SetBearing):
        return b"AP1%03d" % msg.bearing + (b"\r" if msg.go else b";")
    text = _TEXT.get(msg)
    if text is None:
        raise ValueError(f"{msg!r} is not a command a host sends")
    return text


def decode_single(byte: bytes) -> Command | None:
    """A byte that is a whole command when nothing else is pending (``;``, ``V``, an option
    byte), or None. Which of them a controller takes is its business (a DCU-1: ``;`` only)."""
    return _SINGLE.get(byte)


def decode_command(text: bytes, terminator: bytes) -> Command:
    """A command ended by ``;`` or CR (``text`` without the terminator); case-sensitive."""
    if text.startswith(b"AP1") and len(text) == 6 and text[3:].isdigit():
        bearing = int(text[3:])
        return SetBearing(bearing, terminator == b"\r") if bearing <= 360 else Invalid(text)
    return _TERMINATED.get(text + terminator, Invalid(text + terminator))


class RotorEzDriver(LinkDriver):
    """Rotor-EZ / RotorCard (``variant="rotorez"``) or DCU-1 (``variant="dcu1"``).

    ``set_style``: "cr" sends ``AP1ddd\\r`` (set and go, Rotor-EZ), "am" sends ``AP1ddd;``
    then ``AM1;`` (what Hamlib does, and all a DCU-1 understands). Queries retry ``retries``
    times on silence. The DCU-1 runs open loop (see :class:`OpenLoopAz`).
    """

    def __init__(self, port: Port, variant: Literal["rotorez", "dcu1"] = "rotorez", *,
                 timeout_s: float = 1.0, retries: int = 2,
                 set_style: Literal["cr", "am"] | None = None, pace_cmd_s: float = 0.05,
                 accept_old_reply: bool = False, clock: Clock | None = None,
                 rate_deg_s: float = 6.0, start_az_deg: float = 0.0,
                 start_delay_s: float = 0.5, stop_bearing_deg: float = 0.0,
                 spec: RotatorSpec | None = None, has_elevation: bool | None = None,
                 az_max_deg: float | None = None, el_max_deg: float | None = None,
                 autobaud: bool = False):
        # has_elevation / az_max_deg / el_max_deg / autobaud are what generic callers (tracker
        # rotator, tracker track) pass to every driver; this controller is azimuth-only 0-360
        # with no autobaud, so they change nothing.
        if variant not in ("rotorez", "dcu1"):
            raise ConfigError(f"variant must be rotorez or dcu1, got {variant!r}")
        self.variant = variant
        self.link = ByteLink(port, clock, pace_cmd_s)
        self.clock = self.link.clock
        self.timeout_s = float(timeout_s)
        self.retries = int(retries)
        self.set_style = set_style or ("cr" if variant == "rotorez" else "am")
        if self.set_style not in ("cr", "am"):
            raise ConfigError(f"set_style must be 'cr' or 'am', got {set_style!r}")
        if variant == "dcu1" and self.set_style == "cr":
            raise ConfigError("a DCU-1 only understands AP1ddd; + AM1; (set_style='am')")
        self.accept_old_reply = accept_old_reply
        self.capabilities = Capabilities(
            has_elevation=False, has_position_query=variant == "rotorez",
            has_axis_stop=False, has_manual_move=False, has_speed=False, speed_steps=0,
            az_max_deg=360.0, el_max_deg=0.0)
        # open-loop estimate (DCU-1): rate, start delay and stop bearing of the rotator
        self.estimate = open_loop_estimate(self.clock, spec, rate_deg_s, start_delay_s,
                                           start_az_deg, stop_bearing_deg)
        self.stop_on_exit = True

    @classmethod
    def from_url(cls, url: str, variant: Literal["rotorez", "dcu1"] = "rotorez", *,
                 baudrate: int | None = None, **kw: Any) -> RotorEzDriver:
        return driver_on_port(cls, url, variant, port_kw=dict(
            baudrate=baudrate or BAUDRATE, timeout_s=0.05, clock=kw.get("clock")), **kw)

    # Public API --------------------------------------------------------------------------------

    def position(self) -> tuple[float, float | None]:
        """``AI1;`` → bearing (Rotor-EZ); the motor-model estimate on a DCU-1."""
        if not self.capabilities.has_position_query:
            return round(self.estimate.position(), 1), None
        last = b""
        with self.link.lock:
            for _attempt in range(1 + self.retries):
                self.link.flush_input()
                self.link.write(encode(QueryBearing()))
                buf, found = self.link.read_until(self._found_ai, self.timeout_s)
                if found:
                    az = found[0]
                    self.estimate.set(float(min(az, 359)))
                    return float(az), None
                last = buf
        raise RotatorTimeout(
            f"no ;ddd reply to AI1; within {self.timeout_s:g} s after {1 + self.retries} tries"
            + (f" (received {last!r})" if last else "")
            + "; check the port, 4800 baud and that the controller is on")

    def _found_ai(self, buf: bytes) -> tuple[int] | None:
        az = parse_ai_reply(buf, self.accept_old_reply)
        return None if az is None else (az,)

    def goto(self, az_deg: float, el_deg: float | None = None) -> None:
        bearing = int(encode_bearing(az_deg))
        with self.link.lock:
            if self.set_style == "cr":
                self.link.write(encode(SetBearing(bearing, go=True)))
            else:
                self.link.write(encode(SetBearing(bearing, go=False)))
                self.link.write(encode(Execute()))
        self.estimate.command(float(bearing))

    def stop(self) -> None:
        with self.link.lock:
            self.link.write(encode(Stop() if self.variant == "rotorez" else StopAxis()))
        self.estimate.stop()

    def move(self, direction: Direction) -> None:
        raise LimitError(f"{self.variant} has no manual-move command; use goto")

    def set_option(self, name: str, enabled: bool) -> None:
        """Rotor-EZ option switch: endpoint, overshoot, unstick or jam (one byte, no reply)."""
        if self.variant != "rotorez":
            raise LimitError("option commands exist on the Rotor-EZ / RotorCard only")
        if name not in OPTION_BYTES:
            raise ValueError(f"option must be one of {', '.join(OPTION_BYTES)}; got {name!r}")
        with self.link.lock:
            self.link.write(encode(SetOption(name, enabled)))

    def version(self) -> str:
        """``V``: whatever the unit reports (format undocumented), stripped of stray bytes."""
        with self.link.lock:
            self.link.flush_input()
            self.link.write(encode(Version()))
            raw = self.link.collect(0.2, self.timeout_s)
        return raw.decode("ascii", "ignore").strip()



def open_rotorez(protocol: str, url: str, **kw: Any) -> RotorEzDriver:
    """The registry's driver factory: ``protocol`` "rotorez" or "dcu1"."""
    variant: Literal["rotorez", "dcu1"] = "dcu1" if protocol.lower() == "dcu1" else "rotorez"
    return RotorEzDriver.from_url(url, variant, **kw)
