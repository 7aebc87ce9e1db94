"""Helpers for tests, of this project or of code built on it; the product never imports them.

* :func:`synthetic_pass` - a great-circle pass with a chosen culmination (maximum elevation,
  azimuth where it crosses), as a :class:`~tracker.skytrack.SkyTrack`: drives the planner
  through stop crossings and overhead passes without orbit propagation
  (:mod:`tracker.testing.synthpass`).

Only numpy and the sky-track module are imported, so using these costs nothing extra.
"""

from __future__ import annotations

from tracker.testing.synthpass import T0_S, synthetic_pass

__all__ = ["T0_S", "synthetic_pass"]
