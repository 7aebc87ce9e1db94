"""Rotator model: the mechanical frame, rotator specs and presets, and the one motor model.

Frames (docs/architecture.md): the planner works in the *mechanical* frame ``m`` in
``[0, az_span_deg]`` counted clockwise from the CCW stop at ``stop_bearing_deg``; the true
bearing is ``(m + stop_bearing_deg) mod 360``. Elevation above 90 means over the top (flip).
:class:`MountFrame` (``RotatorSpec.frame``) is the one owner of the conversions between true
bearings, mechanical azimuth and the controller's wire degrees.

The motor model (:class:`AxisMotor`, :class:`MotorModel`) is used by the planner to predict
where the antenna will be and by the emulator to move the simulated antenna: one
implementation, so predictions and the emulator's read-back agree by construction.
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

from tracker.errors import ConfigError


@dataclass(frozen=True)
class MountFrame:
    """The azimuth frames of one rotator on one controller, and every conversion between them.

    ``m`` (mechanical) is degrees clockwise from the CCW stop, ``0 <= m <= az_span_deg``; the
    stop points at ``stop_bearing_deg``. *Wire degrees* are what the controller takes and
    reports: ``m`` itself for most controllers (their scale tops at :attr:`wire_az_max_deg`,
    450 on an overlap rotator), or the true bearing for one that maps a south-centred scale
    itself (``wire_takes_bearing``: a GS-232B in its ``Z`` mode, Rotor-EZ, DCU-1, SAK-232).
    """

    az_span_deg: float = 450.0
    stop_bearing_deg: float = 0.0
    wire_takes_bearing: bool = False

    # True bearing <-> mechanical ----------------------------------------------------------

    def bearing_of(self, m_deg: float | ArrayLike) -> Any:
        """True bearing in [0, 360) of a mechanical azimuth (scalar or array)."""
        if isinstance(m_deg, float):   # per-cycle calls: no numpy round trip
            return (m_deg + self.stop_bearing_deg) % 360.0
        return np.mod(np.asarray(m_deg, dtype=float) + self.stop_bearing_deg, 360.0)

    def mech_of(self, bearing_deg: ArrayLike) -> Any:
        """The lowest mechanical azimuth in [0, 360) for a true bearing (scalar or array)."""
        return np.mod(np.asarray(bearing_deg, dtype=float) - self.stop_bearing_deg, 360.0)

    def mech_candidates(self, bearing_deg: float) -> list[float]:
        """Every mechanical azimuth within the span that points at ``bearing_deg``."""
        m0 = float(self.mech_of(bearing_deg))
        return [m for m in (m0, m0 + 360.0) if m <= self.az_span_deg + 1e-9]

    # Mechanical <-> wire ------------------------------------------------------------------

    @property
    def wire_az_max_deg(self) -> float:
        """The top of the controller's azimuth scale: 450 for an overlap rotator whose
        controller takes ``m`` (its 450 deg mode), else 360."""
        return 450.0 if self.az_span_deg > 360.0 and not self.wire_takes_bearing else 360.0

    def mech_max_deg(self, wire_max_deg: float) -> float:
        """The top of the mechanical travel a controller whose scale ends at ``wire_max_deg``
        can reach (a controller taking bearings reaches the whole span)."""
        if self.wire_takes_bearing:
            return float(self.az_span_deg)
        return min(float(self.az_span_deg), float(wire_max_deg))

    def top_command_deg(self, step_deg: float) -> float:
        """The highest mechanical azimuth a command can name. On a 360 deg rotator whose
        controller takes bearings, the CW end is the stop's own bearing, which the controller
        reads as the CCW end: one ``step_deg`` short of it is the top. Else the span."""
        if self.wire_takes_bearing and self.az_span_deg <= 360.0:
            return float(self.az_span_deg) - float(step_deg)
        return float(self.az_span_deg)

    @overload
    def wire_of(self, m_deg: float) -> float: ...

    @overload
    def wire_of(self, m_deg: np.ndarray) -> np.ndarray: ...

    def wire_of(self, m_deg: float | np.ndarray) -> float | np.ndarray:
        """Mechanical azimuth -> what the controller takes on the wire (scalar or array)."""
        m = np.asarray(m_deg, dtype=float)
        wire = self.bearing_of(m) if self.wire_takes_bearing else m
        return float(wire) if np.ndim(wire) == 0 else wire

    def mech_of_wire(self, wire_az_deg: ArrayLike) -> Any:
        """Where a commanded wire azimuth turns the antenna (scalar or array): ``m`` itself,
        or for a controller that takes bearings the lowest mechanical azimuth of it."""
        wire = np.asarray(wire_az_deg, dtype=float)
        return self.mech_of(wire) if self.wire_takes_bearing else wire

    def mechs_of_wire(self, wire_az_deg: float) -> list[float]:
        """Every mechanical azimuth a read-back can mean: controllers fold 0-450 into 0-359 or
        report their own scale, so each reading names up to two positions."""
        if self.wire_takes_bearing:
            return self.mech_candidates(wire_az_deg % 360.0)
        top = self.az_span_deg + 2.0
        out = []
        for m in (wire_az_deg - 360.0, wire_az_deg, wire_az_deg + 360.0):
            if -2.0 <= m <= top:     # (a loop, not a comprehension: once a live-loop cycle)
                out.append(m)
        return out or [min(max(wire_az_deg, 0.0), self.az_span_deg)]

    def nearest_mech_of_wire(self, wire_az_deg: float, belief_m_deg: float | None = None
                             ) -> float:
        """The one of :meth:`mechs_of_wire` nearest ``belief_m_deg`` (where the antenna is
        believed to be). Without a belief: the controller's own scale is trusted (a 450 deg
        controller reports 0-450), and of a bearing the lowest mechanical azimuth."""
        cands = self.mechs_of_wire(wire_az_deg)
        best = cands[0]
        if len(cands) == 1:
            return best
        if belief_m_deg is None:
            if self.wire_takes_bearing:
                return best
            belief_m_deg = wire_az_deg
        # min(cands, key=distance) without a call per candidate (once a live-loop cycle)
        best_off = abs(best - belief_m_deg)
        for m in cands[1:]:
            off = abs(m - belief_m_deg)
            if off < best_off:
                best, best_off = m, off
        return best


@dataclass(frozen=True)
class RotatorSpec:
    """What the planner and the emulator need to know about one rotator + controller.

    Rates are the motor's slew rates in degrees per second at the default speed.
    ``az_speed_rates_deg_s`` lists the azimuth rate for each speed step X1..X4 (slowest
    first) when the controller has them. ``el_max_deg`` is ``None`` for azimuth-only rotators.
    ``controller_maps_south`` is True when the controller takes true bearings and maps a
    south-centred scale itself (GS-232B ``Z``); otherwise it expects mechanical degrees.
    """

    name: str
    az_span_deg: float = 450.0
    stop_bearing_deg: float = 0.0
    el_min_deg: float = 0.0
    el_max_deg: float | None = 180.0
    az_rate_deg_s: float = 6.0
    el_rate_deg_s: float | None = 2.7
    az_speed_rates_deg_s: tuple[float, ...] = ()
    start_delay_s: float = 0.0
    resolution_deg: float = 1.0
    park_az_deg: float = 0.0
    park_el_deg: float = 0.0
    controller_maps_south: bool = False
    deadband_deg: float = 4.0
    description: str = ""
    extra: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        self.validate()

    @property
    def has_elevation(self) -> bool:
        return self.el_max_deg is not None

    # validate() makes el_max_deg and el_rate_deg_s both set whenever the rotator has
    # elevation; these give them as plain floats to code that has checked has_elevation.
    @property
    def el_top_deg(self) -> float:
        """``el_max_deg`` of a rotator with elevation."""
        if self.el_max_deg is None:
            raise ValueError(f"rotator {self.name!r} has no elevation axis")
        return self.el_max_deg

    @property
    def el_rate(self) -> float:
        """``el_rate_deg_s`` of a rotator with elevation."""
        if self.el_rate_deg_s is None:
            raise ValueError(f"rotator {self.name!r} has no elevation axis")
        return self.el_rate_deg_s

    # One guard per field, each with its own message.
    def validate(self) -> None:  # noqa: C901
        def bad(key: str, value: object, allowed: str) -> ConfigError:
            return ConfigError(f"rotator {self.name!r}: {key} = {value!r} is invalid; "
                               f"allowed: {allowed}")

        numeric = ("az_span_deg", "stop_bearing_deg", "el_min_deg", "az_rate_deg_s",
                   "start_delay_s", "resolution_deg", "park_az_deg", "park_el_deg",
                   "deadband_deg")
        for key in (*numeric, "el_max_deg", "el_rate_deg_s"):
            value = getattr(self, key)
            if value is None and key in ("el_max_deg", "el_rate_deg_s"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                    not math.isfinite(value)):
                raise bad(key, value, "a finite number")
        if not (360.0 <= self.az_span_deg <= 450.0):
            raise bad("az_span_deg", self.az_span_deg, "360 to 450 degrees")
        if not (0.0 <= self.stop_bearing_deg < 360.0):
            raise bad("stop_bearing_deg", self.stop_bearing_deg,
                      "0 to <360 (0 = north stop, 180 = south stop)")
        if not (self.az_rate_deg_s > 0 and math.isfinite(self.az_rate_deg_s)):
            raise bad("az_rate_deg_s", self.az_rate_deg_s, "a finite number > 0")
        for i, r in enumerate(self.az_speed_rates_deg_s):
            if isinstance(r, bool) or not isinstance(r, (int, float)) or not (
                    r > 0 and math.isfinite(r)):
                raise bad(f"az_speed_rates_deg_s[{i}]", r, "finite numbers > 0")
        if self.el_max_deg is not None:
            if not (0.0 <= self.el_min_deg < self.el_max_deg <= 180.0):
                raise bad("el_min_deg/el_max_deg", (self.el_min_deg, self.el_max_deg),
                          "0 <= el_min_deg < el_max_deg <= 180")
            if self.el_rate_deg_s is None or not (
                    self.el_rate_deg_s > 0 and math.isfinite(self.el_rate_deg_s)):
                raise bad("el_rate_deg_s", self.el_rate_deg_s, "a finite number > 0")
        if not (0.0 <= self.start_delay_s <= 10.0):
            raise bad("start_delay_s", self.start_delay_s, "0 to 10 seconds")
        if not (0.0 < self.resolution_deg <= 5.0):
            raise bad("resolution_deg", self.resolution_deg, "> 0 and <= 5 degrees")
        if not (0.0 <= self.deadband_deg <= 30.0):
            raise bad("deadband_deg", self.deadband_deg, "0 to 30 degrees")
        if not (0.0 <= self.park_az_deg <= self.az_span_deg):
            raise bad("park_az_deg", self.park_az_deg, f"0 to az_span_deg ({self.az_span_deg})")
        if self.el_max_deg is not None and not (
                self.el_min_deg <= self.park_el_deg <= self.el_max_deg):
            raise bad("park_el_deg", self.park_el_deg,
                      f"el_min_deg to el_max_deg ({self.el_min_deg}-{self.el_max_deg})")

    def with_(self, **changes: Any) -> RotatorSpec:
        return replace(self, **changes)

    # Frames ---------------------------------------------------------------------------------

    @cached_property
    def frame(self) -> MountFrame:
        """This rotator's azimuth frames on its controller (every conversion lives there)."""
        return MountFrame(self.az_span_deg, self.stop_bearing_deg, self.controller_maps_south)

    def bearing_of(self, m_deg: ArrayLike) -> Any:
        """True bearing in [0, 360) of a mechanical azimuth (:meth:`MountFrame.bearing_of`)."""
        return self.frame.bearing_of(m_deg)

    def mech_of(self, bearing_deg: ArrayLike) -> Any:
        """The lowest mechanical azimuth of a true bearing (:meth:`MountFrame.mech_of`)."""
        return self.frame.mech_of(bearing_deg)

    def axis_limits(self) -> tuple[tuple[float, float], tuple[float, float] | None]:
        el = (self.el_min_deg, self.el_max_deg) if self.el_max_deg is not None else None
        return (0.0, self.az_span_deg), el


def _rate(seconds: float, degrees: float) -> float:
    return degrees / seconds


# Rotation times are Yaesu's catalogue / manual specification figures ("approx."), quoted at
# 60 Hz mains for the AC-motor models: G-5500 az 360 deg in ~58 s, el 180 deg in ~67 s;
# G-5400B / G-5600B use the same az/el motor drive family (same figures used here);
# G-400 az 360 deg in ~51 s (G-450A class). The DXA series run DC motors with a speed
# control: G-800DXA 43-99 s, G-1000DXA 40-100 s, G-2800DXA 50-110 s per 360 deg, which the
# GS-232 maps to X1 (slowest) .. X4 (fastest). These figures were taken from the published
# spec tables as recalled; they were NOT re-verified against a stored copy of the catalogue in
# this repository, so measure your own rotator (time a full turn) and override the rate in
# [rotator.NAME] when it matters.
# The 360 deg spans of the G-400 and G-5400B/G-5600B follow the GS-232B manual, which has
# them set to 360 deg mode (P36) at installation.
# AC motors turn in proportion to mains frequency: at 50 Hz they take 6/5 as long.


def _four_speeds(fastest_s: float, slowest_s: float) -> tuple[float, ...]:
    """X1..X4 rates for a DXA speed range, evenly spread in rotation time."""
    times = np.linspace(slowest_s, fastest_s, 4)
    return tuple(round(360.0 / float(t), 3) for t in times)


PRESETS: dict[str, RotatorSpec] = {
    "G-5500": RotatorSpec(
        name="G-5500", az_span_deg=450, stop_bearing_deg=0, el_max_deg=180,
        az_rate_deg_s=_rate(58, 360), el_rate_deg_s=_rate(67, 180), start_delay_s=0.5,
        deadband_deg=4.0,
        description="Yaesu G-5500 az/el, 450 deg azimuth (north stop), 0-180 elevation"),
    "G-5400B": RotatorSpec(
        name="G-5400B", az_span_deg=360, stop_bearing_deg=180, el_max_deg=180,
        az_rate_deg_s=_rate(58, 360), el_rate_deg_s=_rate(67, 180), start_delay_s=0.5,
        deadband_deg=4.0,
        description="Yaesu G-5400B az/el, 360 deg azimuth (south stop), 0-180 elevation"),
    "G-5600B": RotatorSpec(
        name="G-5600B", az_span_deg=360, stop_bearing_deg=180, el_max_deg=180,
        az_rate_deg_s=_rate(58, 360), el_rate_deg_s=_rate(67, 180), start_delay_s=0.5,
        deadband_deg=4.0,
        description="Yaesu G-5600B az/el, 360 deg azimuth (south stop), 0-180 elevation"),
    "G-800DXA": RotatorSpec(
        name="G-800DXA", az_span_deg=450, stop_bearing_deg=0, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=_rate(43, 360),
        az_speed_rates_deg_s=_four_speeds(43, 99), start_delay_s=0.5, deadband_deg=3.0,
        description="Yaesu G-800DXA azimuth-only, 450 deg, four speeds (X1-X4)"),
    "G-1000DXA": RotatorSpec(
        name="G-1000DXA", az_span_deg=450, stop_bearing_deg=0, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=_rate(40, 360),
        az_speed_rates_deg_s=_four_speeds(40, 100), start_delay_s=0.5, deadband_deg=3.0,
        description="Yaesu G-1000DXA azimuth-only, 450 deg, four speeds (X1-X4)"),
    "G-2800DXA": RotatorSpec(
        name="G-2800DXA", az_span_deg=450, stop_bearing_deg=0, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=_rate(50, 360),
        az_speed_rates_deg_s=_four_speeds(50, 110), start_delay_s=0.5, deadband_deg=3.0,
        description="Yaesu G-2800DXA azimuth-only, 450 deg, four speeds (X1-X4)"),
    "G-400": RotatorSpec(
        name="G-400", az_span_deg=360, stop_bearing_deg=180, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=_rate(51, 360), start_delay_s=0.5,
        deadband_deg=4.0,
        description="Yaesu G-400 azimuth-only, 360 deg (south stop)"),
    "generic-k3ng": RotatorSpec(
        name="generic-k3ng", az_span_deg=360, stop_bearing_deg=180, el_max_deg=90,
        az_rate_deg_s=6.0, el_rate_deg_s=3.0, deadband_deg=3.0,
        description="Generic K3NG Arduino controller, 360 deg south-stop, 0-90 elevation"),
    # The default rotators of the azimuth-only controllers' emulators and demos
    # (tracker.controllers names them).
    "HAM-IV": RotatorSpec(
        name="HAM-IV", az_span_deg=360, stop_bearing_deg=180, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=6.0, start_delay_s=0.5, controller_maps_south=True,
        deadband_deg=3.0,
        description="Hy-Gain HAM-IV class azimuth rotator: 360 deg, south stop, ~60 s per "
                    "turn"),
    "Zelpro-RAU": RotatorSpec(
        name="Zelpro-RAU", az_span_deg=360, stop_bearing_deg=0, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=4.0, start_delay_s=0.2, resolution_deg=4 / 6,
        deadband_deg=2.0,
        description="Zelpro RAU rotator on a SAK-232: 360 deg from a north stop, 6 pulses per "
                    "4 deg (rate assumed, not published)"),
    "AZ-360": RotatorSpec(
        name="AZ-360", az_span_deg=360, stop_bearing_deg=0, el_max_deg=None,
        el_rate_deg_s=None, az_rate_deg_s=6.0, start_delay_s=0.5, deadband_deg=3.0,
        description="generic azimuth-only rotator, 360 deg from a north stop, 6 deg/s"),
}

# DC-motor drives (speed set by the controller): mains frequency does not change their rates.
_MAINS_INDEPENDENT = {"g-800dxa", "g-1000dxa", "g-2800dxa", "generic-k3ng"}


def preset(name: str, mains_hz: int = 60) -> RotatorSpec:
    """A preset rotator by case-insensitive name; ``mains_hz=50`` slows AC motors by 5/6."""
    table = {k.lower(): v for k, v in PRESETS.items()}
    spec = table.get(name.lower())
    if spec is None:
        raise ConfigError(f"unknown rotator {name!r}; known presets: {', '.join(PRESETS)} "
                          f"(or define [rotator.{name}] in the config file)")
    if mains_hz == 50:
        if name.lower() in _MAINS_INDEPENDENT:
            return spec
        f = 50.0 / 60.0
        spec = spec.with_(
            az_rate_deg_s=spec.az_rate_deg_s * f,
            el_rate_deg_s=None if spec.el_rate_deg_s is None else spec.el_rate_deg_s * f,
            az_speed_rates_deg_s=tuple(r * f for r in spec.az_speed_rates_deg_s),
            name=f"{spec.name}@50Hz")
    elif mains_hz != 60:
        raise ConfigError(f"mains_hz = {mains_hz!r} is invalid; allowed: 50 or 60")
    return spec


# Motor model ----------------------------------------------------------------------------------

# AxisMotor.stamp: a new number at every change of a segment, in any axis.
_STAMPS = itertools.count()


class AxisMotor:
    """One rate-limited axis, in its own degrees (mechanical azimuth or elevation).

    A command is quantised to ``resolution_deg`` and clamped to ``[min_deg, max_deg]``; the
    motor waits ``start_delay_s`` when it starts from rest or reverses, then moves at
    ``rate_deg_s`` until it reaches the target. A command in the direction the motor is
    already running takes effect without a new start delay. Positions are piecewise linear in
    time, so :meth:`position` is exact and vectorised over ``t_s``.
    """

    def __init__(self, min_deg: float, max_deg: float, rate_deg_s: float,
                 start_delay_s: float = 0.0, resolution_deg: float = 1.0,
                 position_deg: float = 0.0, t_s: float = 0.0):
        self.min_deg = float(min_deg)
        self.max_deg = float(max_deg)
        self.rate_deg_s = float(rate_deg_s)
        self.start_delay_s = float(start_delay_s)
        self.resolution_deg = float(resolution_deg)
        self.jammed = False
        self._t0 = float(t_s)          # start of the current segment
        self._p0 = float(position_deg)  # position at _t0
        self._target = float(position_deg)
        self._delay = 0.0
        # Renewed whenever what the positions follow from may change (a copy keeps it, as it
        # keeps the segment): equal stamps, equal segments (AxisMotor.segment), cheaply.
        self.stamp = next(_STAMPS)

    def quantise(self, target_deg: float) -> float:
        q = round(float(target_deg) / self.resolution_deg) * self.resolution_deg
        return min(max(q, self.min_deg), self.max_deg)

    @property
    def target_deg(self) -> float:
        return self._target

    def position(self, t_s):
        """Position at time(s) ``t_s`` >= the last command (scalar or array)."""
        if type(t_s) is float or isinstance(t_s, (float, int)):  # scalar fast path
            if self.jammed:
                return float(self._p0)
            dist = self._target - self._p0
            if dist == 0.0 and t_s == t_s:   # at rest on its target (most live-loop asks)
                return self._p0 + 0.0
            # min(max(run, 0.0), abs(dist)) without the calls (several times a live-loop
            # cycle, and every emulator tick)
            run = (t_s - self._t0 - self._delay) * self.rate_deg_s
            if 0.0 > run:
                run = 0.0
            span = abs(dist)
            return self._p0 + math.copysign(span if span < run else run, dist)
        t = np.asarray(t_s, dtype=float)
        if self.jammed:
            return np.full(t.shape, self._p0) if t.ndim else float(self._p0)
        dist = self._target - self._p0
        moved = np.clip((t - self._t0 - self._delay) * self.rate_deg_s, 0.0, abs(dist))
        pos = self._p0 + math.copysign(1.0, dist) * moved
        return pos if t.ndim else float(pos)

    def direction(self, t_s: float) -> int:
        """+1 / -1 while moving at ``t_s``, 0 at rest."""
        if self.jammed:
            return 0
        p = self.position(t_s)
        if abs(self._target - p) < 1e-9:
            return 0
        return 1 if self._target > p else -1

    def moving(self, t_s: float, position_deg: float | None = None) -> bool:
        """True while the axis runs at ``t_s``; ``position_deg``, if given, is
        :meth:`position` at ``t_s`` (a caller that has it saves evaluating it again)."""
        if self.jammed or self._p0 == self._target:
            return False
        if position_deg is None:
            position_deg = self.position(t_s)
        return not abs(self._target - position_deg) < 1e-9

    def rests_on(self, position_deg: float) -> bool:
        """True if the axis stands on ``position_deg`` with that as its target (exactly, not
        jammed): nothing it does depends on time then."""
        return self._p0 == position_deg and self._target == position_deg and not self.jammed

    def arrival_s(self) -> float:
        """Time at which the current target is (or was) reached."""
        return self._t0 + self._delay + abs(self._target - self._p0) / self.rate_deg_s

    def command(self, target_deg: float, t_s: float) -> float:
        """Start moving to ``target_deg`` at ``t_s``; returns the quantised, clamped target."""
        p = self.position(t_s)
        target = self.quantise(target_deg)
        was = self.direction(t_s)
        new = 0 if abs(target - p) < 1e-9 else (1 if target > p else -1)
        if was != 0 and new == was:
            # Relay already closed in this direction: no new start delay, but a motor that
            # is still inside its start delay keeps waiting the rest of it.
            delay = max(0.0, self._t0 + self._delay - t_s)
        else:
            delay = self.start_delay_s if new != 0 else 0.0
        self._t0, self._p0, self._target, self._delay = float(t_s), float(p), target, delay
        self.stamp = next(_STAMPS)
        return target

    def segment(self) -> tuple[float, float, float, float, float, bool]:
        """What its positions follow from (start time, position then, target, start delay,
        rate, jammed): two axes with equal segments are at the same place at every time."""
        return self._t0, self._p0, self._target, self._delay, self.rate_deg_s, self.jammed

    def rest_at(self, position_deg: float, t_s: float) -> None:
        """Stand still on ``position_deg`` from ``t_s`` on, as a new axis does (not jammed)."""
        self.jammed = False
        self._t0 = float(t_s)
        self._p0 = self._target = float(position_deg)
        self._delay = 0.0
        self.stamp = next(_STAMPS)

    def stop(self, t_s: float) -> None:
        p = self.position(t_s)
        self._t0, self._p0, self._target, self._delay = float(t_s), float(p), float(p), 0.0
        self.stamp = next(_STAMPS)

    def set_rate(self, rate_deg_s: float, t_s: float) -> None:
        """Change speed now (GS-232 X1..X4 takes effect even during rotation)."""
        if rate_deg_s <= 0:
            raise ValueError("rate_deg_s must be > 0")
        target = self._target
        remaining_delay = max(0.0, self._t0 + self._delay - t_s)
        p = self.position(t_s)
        self.rate_deg_s = float(rate_deg_s)
        self._t0, self._p0, self._target, self._delay = float(t_s), float(p), target, \
            remaining_delay
        self.stamp = next(_STAMPS)

    def jam(self, t_s: float, jammed: bool = True) -> None:
        """Fault injection: the axis stops turning (motor stalled, brake stuck)."""
        p = self.position(t_s)
        self._t0, self._p0 = float(t_s), float(p)
        if not jammed:
            self._target, self._delay = float(p), 0.0
        self.jammed = jammed
        self.stamp = next(_STAMPS)


class MotorModel:
    """The two axes of one rotator (elevation absent for azimuth-only rotators)."""

    def __init__(self, spec: RotatorSpec, az_deg: float | None = None,
                 el_deg: float | None = None, t_s: float = 0.0):
        self.spec = spec
        (az_min, az_max), el_lim = spec.axis_limits()
        self.az = AxisMotor(az_min, az_max, spec.az_rate_deg_s, spec.start_delay_s,
                            spec.resolution_deg,
                            spec.park_az_deg if az_deg is None else az_deg, t_s)
        self.el: AxisMotor | None = None
        if el_lim is not None:
            self.el = AxisMotor(el_lim[0], el_lim[1], spec.el_rate, spec.start_delay_s,
                                spec.resolution_deg,
                                spec.park_el_deg if el_deg is None else el_deg, t_s)

    def position(self, t_s: float) -> tuple[float, float]:
        el = self.el.position(t_s) if self.el is not None else 0.0
        return self.az.position(t_s), el

    def command(self, az_deg: float, el_deg: float | None, t_s: float) -> tuple[float, float]:
        a = self.az.command(az_deg, t_s)
        e = 0.0
        if self.el is not None and el_deg is not None:
            e = self.el.command(el_deg, t_s)
        return a, e

    def stop(self, t_s: float) -> None:
        self.az.stop(t_s)
        if self.el is not None:
            self.el.stop(t_s)

    def moving(self, t_s: float) -> bool:
        return self.az.moving(t_s) or (self.el is not None and self.el.moving(t_s))


def move_from_rest(start_deg: np.ndarray | float, target_deg: np.ndarray | float,
                   dt_s: np.ndarray | float, rate_deg_s: float,
                   start_delay_s: float) -> np.ndarray:
    """Where an axis at rest on ``start_deg`` is ``dt_s`` after being told to go to
    ``target_deg``: :class:`AxisMotor`'s kinematics (start delay, then constant rate),
    broadcast over any shapes."""
    return moves_from_rest(start_deg, target_deg, rate_deg_s, start_delay_s)(dt_s)


def moves_from_rest(start_deg: np.ndarray | float, target_deg: np.ndarray | float,
                    rate_deg_s: float, start_delay_s: float
                    ) -> Callable[[np.ndarray | float], np.ndarray]:
    """:func:`move_from_rest` as a function of ``dt_s`` alone: what depends only on the
    start and the targets (distance, direction, start delay) is worked out once, for a
    caller that asks about one set of moves over several stretches of time (the aim
    policy's error blocks)."""
    dist = np.asarray(target_deg, dtype=float) - start_deg
    span = np.abs(dist)
    wait_s = np.where(span > 1e-9, start_delay_s, 0.0)
    sign = np.sign(dist)

    def at(dt_s: np.ndarray | float) -> np.ndarray:
        # np.minimum(np.maximum(...)) is np.clip's result at a fraction of its call cost.
        travelled = np.minimum(np.maximum((dt_s - wait_s) * rate_deg_s, 0.0), span)
        return start_deg + sign * travelled

    return at


def drive_axis(axis: AxisMotor, cmd_t_s: ArrayLike, cmd_deg: ArrayLike, t_eval_s: ArrayLike,
               *, closed_form: bool = True) -> tuple[np.ndarray, int]:
    """Drive ``axis`` through ``cmd_deg`` commanded at ``cmd_t_s``: ``(positions at
    t_eval_s, motor starts)``.

    A start is a command that sets a resting (or reversing) axis moving: the relay closes.
    ``axis`` is advanced (mutated) through every command; samples before the first command get
    its position then. While each move ends before the next command (the normal case when
    tracking with small steps) every command is a start from rest, so positions follow in
    closed form for all samples at once; the stretches where the motor is still running when
    the next command arrives (a long slew, an unwind), an axis already moving at the first
    command, and ``closed_form=False`` (the reference the closed form is tested against) step
    through :meth:`AxisMotor.command` itself, so both ways are the one motor model.
    """
    cmd_t = np.asarray(cmd_t_s, dtype=float)
    cmd = np.asarray(cmd_deg, dtype=float)
    t_eval = np.asarray(t_eval_s, dtype=float)
    n = len(cmd_t)
    if not closed_form or (n and axis.moving(float(cmd_t[0]))):
        return _step_commands(axis, cmd_t, cmd, t_eval)
    out = np.empty(t_eval.shape)
    p0 = float(axis.position(cmd_t[0] if n else 0.0))
    if n == 0:
        out[:] = axis.position(t_eval)
        return out, 0
    cmd, prev, moving, _start, arrival = _closed_form_moves(axis, cmd_t, cmd, p0)
    next_t = np.concatenate((cmd_t[1:], [np.inf]))
    overlap = arrival > next_t + 1e-9
    if axis.jammed:
        overlap[:] = True

    # Closed form: command i moves from prev[i] (reached) toward cmd[i] after its delay.
    idx = np.searchsorted(cmd_t, t_eval, side="right") - 1
    before = idx < 0
    i = np.clip(idx, 0, n - 1)
    out[:] = move_from_rest(prev[i], cmd[i], t_eval - cmd_t[i], axis.rate_deg_s,
                            axis.start_delay_s)
    out[before] = axis.position(t_eval[before])   # as stepping gives them
    stepped = np.zeros(n, dtype=bool)     # commands stepped below, counted there
    starts = 0

    # Stretches where moves overlap: step the real AxisMotor command by command.
    overlap_idx = np.flatnonzero(overlap)
    k = 0
    while k < len(overlap_idx):
        j = int(overlap_idx[k])
        _rest_at(axis, float(prev[j]), float(cmd_t[j]))
        last = j
        while last < n:
            tc = float(cmd_t[last])
            was = axis.direction(tc)
            axis.command(float(cmd[last]), tc)
            if axis.direction(tc) not in (0, was):
                starts += 1
            lo = np.searchsorted(t_eval, cmd_t[last], side="left")
            hi = np.searchsorted(t_eval, next_t[last], side="left")
            if hi > lo:
                out[lo:hi] = axis.position(t_eval[lo:hi])
            caught = axis.arrival_s() <= next_t[last] + 1e-9 and not axis.jammed
            stepped[last] = True
            last += 1
            if caught:
                break
        # Commands after the stretch start from rest on cmd[last - 1]: closed form holds.
        while k < len(overlap_idx) and overlap_idx[k] < last:
            k += 1
    # Every other command starts from rest where the one before it ended: a start if it moves.
    starts += int(np.count_nonzero(moving & ~stepped))
    if not overlap[n - 1]:
        # Leave the axis where the last command put it, as stepping would.
        _rest_at(axis, float(prev[-1]), float(cmd_t[-1]))
        axis.command(float(cmd[-1]), float(cmd_t[-1]))
    return out, starts


def _step_commands(axis: AxisMotor, cmd_t: np.ndarray, cmd: np.ndarray,
                   t_eval: np.ndarray) -> tuple[np.ndarray, int]:
    """:func:`drive_axis` one :meth:`AxisMotor.command` at a time, vectorised over the
    samples between commands."""
    out = np.empty(t_eval.shape)
    bounds = np.searchsorted(t_eval, cmd_t, side="left")
    first = bounds[0] if len(cmd_t) else len(t_eval)
    out[:first] = axis.position(t_eval[:first])
    starts = 0
    for i, (tc, target) in enumerate(zip(cmd_t, cmd, strict=True)):
        was = axis.direction(float(tc))
        axis.command(float(target), float(tc))
        if axis.direction(float(tc)) not in (0, was):
            starts += 1
        lo = bounds[i]
        hi = bounds[i + 1] if i + 1 < len(bounds) else len(t_eval)
        if hi > lo:
            out[lo:hi] = axis.position(t_eval[lo:hi])
    return out, starts


def _rest_at(axis: AxisMotor, position_deg: float, t_s: float) -> None:
    """Put ``axis`` at rest on ``position_deg`` at ``t_s`` (a known, reached target)."""
    axis.stop(t_s)
    axis._p0 = axis._target = position_deg
    axis.stamp = next(_STAMPS)


def _closed_form_moves(axis: AxisMotor, cmd_t: np.ndarray, cmd_deg: np.ndarray, p0_deg: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The commands as ``axis`` takes them if each starts from rest where the one before
    ended (``p0_deg`` before the first), the case :func:`drive_axis` takes in closed form:
    (quantised and clamped targets, where each move starts from, which ones move, when each
    starts turning, when each arrives)."""
    res = axis.resolution_deg
    cmd = np.clip(np.round(cmd_deg / res) * res, axis.min_deg, axis.max_deg)
    prev = np.concatenate(([p0_deg], cmd[:-1]))
    span = np.abs(cmd - prev)
    moving = span > 1e-9
    start = cmd_t + np.where(moving, axis.start_delay_s, 0.0)
    return cmd, prev, moving, start, start + span / axis.rate_deg_s


def bends_s(axis: AxisMotor, cmd_t_s: ArrayLike, cmd_deg: ArrayLike) -> np.ndarray:
    """The instants at which ``axis`` driven through ``cmd_deg`` at ``cmd_t_s`` (as
    :func:`drive_axis` drives it) starts or stops turning: where its position bends, so where
    an error sampled on a grid can peak between two samples (``axis`` not mutated). Unsorted,
    and may hold an instant twice.

    The start and arrival of the move the axis was making before the first command are given
    too. Where a move is still running at a command, every command's instant is given (a
    reversal, or a command to where the axis is, stops it there) and the start and arrival of
    every segment: a few that are not bends (a retarget in the running direction, an arrival
    that never comes), none that is missed."""
    cmd_t = np.asarray(cmd_t_s, dtype=float)
    cmd = np.asarray(cmd_deg, dtype=float)
    if len(cmd_t) == 0:
        return np.zeros(0)
    here_deg = float(axis.position(float(cmd_t[0])))
    _cmd, _prev, moving, start, arrival = _closed_form_moves(axis, cmd_t, cmd, here_deg)
    next_t = np.concatenate((cmd_t[1:], [np.inf]))
    if not (axis.jammed or axis.moving(float(cmd_t[0])) or np.any(arrival > next_t + 1e-9)):
        return np.concatenate((_segment_bends(axis), start[moving], arrival[moving]))
    # Step a copy of the axis, as drive_axis does in this case.
    ax = copy.copy(axis)
    out = list(_segment_bends(ax))
    for tc, target in zip(cmd_t, cmd, strict=True):
        ax.command(float(target), float(tc))
        out += [float(tc), *_segment_bends(ax)]
    return np.asarray(out)


def _segment_bends(axis: AxisMotor) -> tuple[float, ...]:
    """When ``axis``'s current segment starts turning and when it arrives (none at rest or
    jammed)."""
    t0_s, from_deg, to_deg, delay_s, _rate, jammed = axis.segment()
    if to_deg == from_deg or jammed:
        return ()
    return t0_s + delay_s, axis.arrival_s()
