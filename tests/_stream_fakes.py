"""Helpers for the stream tests: synthetic passes and an in-process rotator on THE motor model.

The fake rotator is for the pure decision-logic tests only (no protocol, no bytes); protocol
behaviour is tested over a real pty / TCP socket against the emulator in test_stream_e2e.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracker.errors import PortLostError, RotatorTimeout
from tracker.mount import MotorModel, RotatorSpec
from tracker.skytrack import SkyTrack

T0 = 1787400000.0  # 2026-08-22 (bundled TLE epochs), fixed


@dataclass(frozen=True)
class SimplePlan:
    """The MountPlan fields the live loop reads (the real planner has more)."""

    t_s: np.ndarray
    cmd_az_deg: np.ndarray
    cmd_el_deg: np.ndarray
    mode: str
    preposition_t_s: float
    preposition: tuple[float, float]


def arc_pass(duration_s: float = 600.0, az0_deg: float = 100.0, az1_deg: float = 260.0,
             max_el_deg: float = 60.0, pad_s: float = 60.0, t0_s: float = T0):
    """A smooth synthetic pass (az linear, el half-sine) with ``pad_s`` below the horizon."""
    t = np.arange(t0_s - pad_s, t0_s + duration_s + pad_s + 0.5, 1.0)
    f = (t - t0_s) / duration_s
    az = az0_deg + (az1_deg - az0_deg) * f
    el = max_el_deg * np.sin(np.pi * f)
    return SkyTrack.from_azel(t, az, el, name="ARC")


def simple_plan(track: SkyTrack, spec: RotatorSpec, lead_s: float = 45.0) -> SimplePlan:
    """Follow the track in the mechanical frame (no stop crossing in these passes)."""
    m = np.asarray(spec.mech_of(track.az_deg), dtype=float)
    m = np.unwrap(np.radians(m), period=2 * np.pi)
    m = np.degrees(m)
    el = np.clip(track.el_deg, max(spec.el_min_deg, 0.0), spec.el_max_deg or 90.0)
    up = np.flatnonzero(track.el_deg >= 0)
    aos_i = up[0]
    return SimplePlan(track.t_s, m, el, "normal", float(track.t_s[aos_i] - lead_s),
                      (float(m[aos_i]), float(el[aos_i])))


class FakeRotator:
    """A rotator that obeys the motor model on a clock, speaking wire degrees (ints)."""

    def __init__(self, spec: RotatorSpec, clock, az_deg: float = 0.0, el_deg: float = 0.0):
        self.clock = clock
        self.model = MotorModel(spec, az_deg, el_deg, clock.timestamp())
        self.written: list[str] = []
        self.closed = False
        self.off = False          # control box off: reads AZ=-001 EL=-002
        self.lost = False         # port gone: every call raises PortLostError
        self.fold_360 = False     # report 0..359 even in the overlap
        self.silent = False       # answers nothing: every query times out

    def _check(self):
        if self.lost or self.closed:
            raise PortLostError("fake port lost")

    def position(self):
        self._check()
        if self.silent:
            raise RotatorTimeout("no reply to C2 within 1 s")
        if self.off:
            return -1.0, -2.0
        az, el = self.model.position(self.clock.timestamp())
        az = round(az)
        return float(az % 360 if self.fold_360 else az), float(round(el))

    def goto(self, az_deg, el_deg=None):
        self._check()
        self.written.append(f"W{az_deg:03.0f} {el_deg:03.0f}")
        self.model.command(az_deg, el_deg, self.clock.timestamp())

    def stop(self):
        self._check()
        self.written.append("S")
        self.model.stop(self.clock.timestamp())

    def close(self):
        self.closed = True
