"""Az/el pointing files (``schedule:FILE`` targets): a user-given pointing plan (band openings,
custom sweeps). Not to be confused with :mod:`tracker.pass_schedule`, which picks passes.

Format (CSV, one point per line)::

    # comments start with '#'; blank lines are ignored
    utc_time,az_deg,el_deg            <- optional header (first line whose az is not a number)
    2026-08-22T18:00:00Z,270,5
    2026-08-22T18:30:00Z,300.5,12

- ``utc_time``: ISO 8601; ``Z``/offsets are converted to UTC, a time without offset is UTC.
  Times must be strictly increasing.
- ``az_deg``: true bearing 0..360 (360 = 0).
- ``el_deg`` (optional, but all rows or none): -5..180. Above 90 is "over the top" notation and
  is stored as the same sky direction (az + 180, 180 - el); the planner decides whether to flip.
  Without an el column the schedule is azimuth-only and el is 0 (the horizon).

Between rows the direction is interpolated linearly in time; azimuth goes the **shortest way**
round the circle (350 -> 10 passes north). Put intermediate rows in for sweeps longer than
180° between two rows. Outside the file's time span az and el are NaN (no pointing defined).

Bad files raise :class:`ScheduleError` with ``file:line: what is wrong``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tle.textfile import read_text_file
from tracker.errors import ConfigError
from tracker.skytrack import SkyTrack
from tracker.station import Station
from tracker.timescale import parse_iso_utc, to_datetime

EL_MIN_DEG = -5.0
EL_MAX_DEG = 180.0
FORMAT_HELP = "expected 'utc_time,az_deg[,el_deg]' e.g. '2026-08-22T18:00:00Z,270,5'"


class ScheduleError(ConfigError):
    """A schedule file that cannot be used; the message starts with ``file:line:``."""


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# A line parser: one guard per rule of the file format, each with its own message.
def parse_schedule(text: str, source: str = "<schedule>"  # noqa: C901
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """``(t_s, az_deg, el_deg or None)`` from schedule text; ScheduleError on bad lines."""
    times: list[float] = []
    azs: list[float] = []
    els: list[float] = []
    n_cols: int | None = None
    seen_data = False
    for line_no, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = [p.strip() for p in line.split(",")]
        where = f"{source}:{line_no}"
        if not seen_data and len(parts) >= 2 and not _is_number(parts[1]):
            seen_data = True  # a header line; only allowed before the first point
            continue
        seen_data = True
        if len(parts) not in (2, 3):
            raise ScheduleError(f"{where}: {len(parts)} fields; {FORMAT_HELP}, "
                                f"got {raw.strip()!r}")
        if n_cols is None:
            n_cols = len(parts)
        elif len(parts) != n_cols:
            raise ScheduleError(f"{where}: {len(parts)} fields but the first point has {n_cols};"
                                " give el_deg on every line or on none")
        try:
            t_s = parse_iso_utc(parts[0]).timestamp()
        except ValueError:
            raise ScheduleError(f"{where}: cannot read time {parts[0]!r}; use ISO 8601 UTC "
                                "such as 2026-08-22T18:00:00Z") from None
        try:
            values = [float(p) for p in parts[1:]]
        except ValueError:
            raise ScheduleError(f"{where}: az/el must be numbers in degrees; {FORMAT_HELP}, "
                                f"got {raw.strip()!r}") from None
        if not all(np.isfinite(values)):
            raise ScheduleError(f"{where}: az/el must be finite numbers, got {raw.strip()!r}")
        az = values[0]
        if not 0.0 <= az <= 360.0:
            raise ScheduleError(f"{where}: azimuth {az:g} is out of range; allowed 0 to 360 "
                                "degrees")
        if len(values) == 2 and not EL_MIN_DEG <= values[1] <= EL_MAX_DEG:
            raise ScheduleError(f"{where}: elevation {values[1]:g} is out of range; allowed "
                                f"{EL_MIN_DEG:g} to {EL_MAX_DEG:g} degrees")
        if times and t_s <= times[-1]:
            prev = to_datetime(times[-1]).isoformat()
            raise ScheduleError(f"{where}: time {parts[0]} is not after the previous point "
                                f"({prev}); times must be strictly increasing")
        times.append(t_s)
        azs.append(az)
        if len(values) == 2:
            els.append(values[1])
    if len(times) < 2:
        raise ScheduleError(f"{source}: a schedule needs at least two points; {FORMAT_HELP}")
    t = np.asarray(times)
    az = np.asarray(azs)
    if not els:
        return t, np.mod(az, 360.0), None
    el = np.asarray(els)
    over = el > 90.0
    az = np.where(over, az + 180.0, az)
    el = np.where(over, 180.0 - el, el)
    return t, np.mod(az, 360.0), el


@dataclass(frozen=True)
class ScheduleTarget:
    """A Target that follows an az/el schedule (``kind`` "schedule")."""

    name: str
    t_s: np.ndarray = field(repr=False)
    az_deg: np.ndarray = field(repr=False)
    el_deg: np.ndarray = field(repr=False)
    az_only: bool = False
    path: Path | None = None
    kind: str = "schedule"

    @classmethod
    def load(cls, path: str | Path) -> ScheduleTarget:
        path = Path(path)
        text = read_text_file(path, "schedule file", ScheduleError, hint=FORMAT_HELP)
        return cls.from_text(text, path.stem, source=str(path), path=path)

    @classmethod
    def from_text(cls, text: str, name: str = "schedule", source: str = "<schedule>",
                  path: Path | None = None) -> ScheduleTarget:
        t, az, el = parse_schedule(text, source)
        az_only = el is None
        if el is None:
            el = np.zeros_like(t)
        return cls(name, t, az, el, az_only, path)

    @property
    def span_s(self) -> tuple[float, float]:
        return float(self.t_s[0]), float(self.t_s[-1])

    def observe(self, station: Station, t_s) -> SkyTrack:
        """Interpolated direction at ``t_s`` (NaN outside the file's span); station unused.

        Azimuth is interpolated the shortest way round; range and range rate are NaN.
        """
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        az, el = self.elevation(station, t_s)
        nan = np.full(t_s.shape, np.nan)
        return SkyTrack(t_s, az, el, nan, nan.copy(), np.zeros(t_s.shape, dtype=bool),
                        self.name, {"kind": self.kind, "az_only": self.az_only,
                                    "path": str(self.path) if self.path else None})

    def elevation(self, station: Station | None, t_s) -> tuple[np.ndarray, np.ndarray]:
        """``(az_deg, el_deg)`` at times in any order or shape; NaN outside the span."""
        t_s = np.asarray(t_s, dtype=float)
        # Unwrapping turns each step into the short way (|step| <= 180) before interpolating.
        az_unwrapped = np.degrees(np.unwrap(np.radians(self.az_deg)))
        az = np.mod(np.interp(t_s, self.t_s, az_unwrapped), 360.0)
        el = np.interp(t_s, self.t_s, self.el_deg)
        outside = (t_s < self.t_s[0]) | (t_s > self.t_s[-1])
        return np.where(outside, np.nan, az), np.where(outside, np.nan, el)

    def track(self) -> SkyTrack:
        """The schedule's own points as a SkyTrack (no resampling)."""
        return SkyTrack.from_azel(self.t_s, self.az_deg, self.el_deg, name=self.name,
                                  kind=self.kind, az_only=self.az_only)
