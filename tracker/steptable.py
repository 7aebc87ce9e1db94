"""Step tables: compile a mount path into GS-232 long-form ``W``/``M`` tables, encode, chain.

Semantics modelled exactly as the manuals describe them (docs/protocols.md, Step tables):

* the long-form ``Wsss aaa eee ...`` / ``Msss aaa ...`` line stores the list and turns the
  rotator to point 1 at once, then waits;
* ``T`` turns it to point 2 at once, then to point k+1 every ``sss`` seconds (K3NG firmware:
  every ``sss + 1`` seconds because of its integer-second comparison);
* after the last point the rotator stays there.

So point ``i`` (0-based) of a table is commanded when the upload arrives (``i == 0``) or at
``T + (i - 1) * period_s``, and held until the next one. The compiler picks every point, in
integer controller degrees, to minimise the pointing error over its hold window, given the
slew from the previous point (rate, start delay, 1° steps), then predicts the error and the
motor starts by driving THE motor model (:mod:`tracker.mount`) through the whole schedule.

A pass needing more points than the controller holds is split into chained tables: table
``k+1`` starts with the point due at the end of table ``k``; the host starts sending it one
wire time earlier so it lands on time, then sends its ``T`` one period later.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from tle.textfile import read_text_file
from tracker.controllers import find
from tracker.errors import ConfigError, LimitError, with_advice
from tracker.geometry import MountPath, pointing_error_deg, raise_to_mask, slew_s
from tracker.mount import MotorModel, RotatorSpec, drive_axis, move_from_rest
from tracker.protocols.gs232_tables import (
    INTERVAL_MAX_S,
    INTERVAL_MIN_S,
    decode_table_line,
    encode_table_line,
)
from tracker.skytrack import SkyTrack, azel_to_enu

if TYPE_CHECKING:  # pragma: no cover - typing only
    from tracker.station import Station

# Host-side margin so the pre-position finishes before AOS even with a slow first reply.
PREPOSITION_MARGIN_S = 5.0
# How a Python caller makes a plan file, named in the advice of errors about one (the CLI
# puts its own command there).
MAKE_PLAN = "compile_pass() and write_plan_file()"
BITS_PER_BYTE = 10  # 8N1: start + 8 data + stop


# Controller table profiles ------------------------------------------------------------------


@dataclass(frozen=True)
class TableProfile:
    """What one controller accepts in a timed table.

    ``max_line_chars`` counts the characters before the CR (0 = no limit). ``lines_append``:
    several long-form ``W`` lines add to one list (K3NG does not clear on ``W``), so a table may
    span lines; otherwise a table is exactly one line. ``period_extra_s`` is added to ``sss``
    to get the real step period (K3NG: 1 s).
    """

    name: str
    max_w_pairs: int = 1900
    max_m_angles: int = 3800
    max_line_chars: int = 0
    lines_append: bool = False
    period_extra_s: int = 0
    w_az_max_deg: int = 450
    m_az_max_deg: int = 450
    el_max_deg: int = 180
    clears_at_end: bool = False
    n_reports_index: bool = True

    def max_points(self, kind: str) -> int:
        """Points per table for ``kind`` ("W" or "M"), line-length limits included."""
        limit = self.max_w_pairs if kind == "W" else self.max_m_angles
        if self.max_line_chars:
            per_line = (self.max_line_chars - 4) // _chars_per_point(kind)
            if not self.lines_append or kind == "M":
                limit = min(limit, per_line)
        return limit

    def az_max_deg(self, kind: str) -> int:
        return self.w_az_max_deg if kind == "W" else self.m_az_max_deg

    def period_s(self, interval_s: int) -> int:
        return int(interval_s) + self.period_extra_s


PROFILES: dict[str, TableProfile] = {
    "gs232a": TableProfile("gs232a"),
    "gs232b": TableProfile("gs232b"),
    # K3NG FEATURE_TIMED_BUFFER: 20 entries, 50-byte line buffer without a bounds check,
    # W appends (M clears), W azimuth 0-360 only, real period sss+1, N returns the count only,
    # the list is cleared after the last point (docs/protocols.md, K3NG).
    "k3ng": TableProfile("k3ng", max_w_pairs=20, max_m_angles=20, max_line_chars=50,
                         lines_append=True, period_extra_s=1, w_az_max_deg=360,
                         clears_at_end=True, n_reports_index=False),
}


def table_profile(name: str) -> TableProfile:
    """The table profile of a controller protocol name (``gs232a``, ``gs232b-manual``,
    ``k3ng`` ...: the registry's ``step_tables``), or of a profile name (a plan file's)."""
    entry = find(name)
    key = entry.step_tables if entry is not None else name.lower()
    profile = PROFILES.get(key) if key else None
    if profile is None:
        raise ConfigError(f"protocol {name!r} has no timed step tables; use one of: "
                          f"{', '.join(PROFILES)}")
    return profile


def _chars_per_point(kind: str) -> int:
    return 8 if kind == "W" else 4


# Tables ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class StepTable:
    """One uploadable table: ``kind`` "W" (az/el pairs) or "M" (azimuths).

    ``az_deg`` / ``el_deg`` are integer wire degrees (what goes on the line). ``upload_t_s``
    is when the host starts sending, ``arrive_t_s`` when point 1 is due (the line's CR),
    ``start_t_s`` when ``T`` must be sent (UTC POSIX seconds).
    """

    kind: str
    interval_s: int
    period_s: float
    az_deg: np.ndarray
    el_deg: np.ndarray | None
    upload_t_s: float
    arrive_t_s: float
    start_t_s: float
    profile: TableProfile

    def __len__(self) -> int:
        return len(self.az_deg)

    @property
    def points(self) -> list[tuple[int, int]] | list[int]:
        if self.kind == "W":
            assert self.el_deg is not None, "a W table has elevations"
            return [(int(a), int(e)) for a, e in zip(self.az_deg, self.el_deg, strict=True)]
        return [int(a) for a in self.az_deg]

    def command_times(self) -> np.ndarray:
        """When each point is commanded: arrival for point 1, then T + (i-1)·period."""
        i = np.arange(len(self), dtype=float)
        t = self.start_t_s + (i - 1.0) * self.period_s
        t[0] = self.arrive_t_s
        return t

    @property
    def end_t_s(self) -> float:
        """When the last point's hold window ends."""
        return self.start_t_s + (len(self) - 1) * self.period_s

    def lines(self) -> list[str]:
        """The exact command lines (without CR), validated against the profile."""
        validate_table(self)
        return _encode_lines(self.kind, self.interval_s, self.az_deg, self.el_deg,
                             self._points_per_line(), self.profile)

    def encode(self) -> bytes:
        return "".join(line + "\r" for line in self.lines()).encode("ascii")

    def wire_bytes(self) -> int:
        return len(self.encode())

    def wire_time_s(self, baud: int = 9600) -> float:
        return self.wire_bytes() * BITS_PER_BYTE / float(baud)

    def _points_per_line(self) -> int:
        if self.profile.max_line_chars:
            return (self.profile.max_line_chars - 4) // _chars_per_point(self.kind)
        return max(1, len(self))

    def index_at(self, t_s: float) -> int:
        """1-based index of the point the controller should be on at ``t_s`` (0 before)."""
        return int(np.searchsorted(self.command_times(), t_s, side="right"))

    def remaining_from(self, t_s: float, upload_s: float) -> StepTable | None:
        """The rest of this table, to resync a controller that lost its place at ``t_s``.

        Point 1 of the result is the point due when a fresh upload started at ``t_s`` lands
        (``t_s + upload_s``); its T is when the next point is due. ``None`` when fewer than
        two points are left (the caller sends the last point as a short command).
        """
        arrive = t_s + upload_s
        i0 = max(self.index_at(arrive) - 1, 0)
        if len(self) - i0 < 2:
            return None
        times = self.command_times()
        return replace(self, az_deg=self.az_deg[i0:],
                       el_deg=None if self.el_deg is None else self.el_deg[i0:],
                       upload_t_s=t_s, arrive_t_s=arrive, start_t_s=float(times[i0 + 1]))


def _encode_lines(kind: str, interval_s: int, az: Sequence[float] | np.ndarray,
                  el: Sequence[float] | np.ndarray | None, per_line: int,
                  profile: TableProfile) -> list[str]:
    """The table as long-form lines of at most ``per_line`` points (the shared GS-232 codec)."""
    lines = []
    for lo in range(0, len(az), per_line):
        hi = lo + per_line
        lines.append(encode_table_line(kind, interval_s, az[lo:hi],
                                       None if el is None else el[lo:hi],
                                       az_max_deg=profile.az_max_deg(kind),
                                       el_max_deg=profile.el_max_deg))
    return lines


def validate_table(table: StepTable) -> None:
    """Refuse (LimitError) a table the controller would not take, before anything is sent."""
    p, kind, n = table.profile, table.kind, len(table)
    if kind not in ("W", "M"):
        raise LimitError(f"table kind {kind!r} is invalid; use W (az/el) or M (azimuth)")
    if not (isinstance(table.interval_s, (int, np.integer))
            and INTERVAL_MIN_S <= table.interval_s <= INTERVAL_MAX_S):
        raise LimitError(f"table interval {table.interval_s!r} s is invalid; the controller "
                         f"takes whole seconds {INTERVAL_MIN_S:03d}-{INTERVAL_MAX_S}")
    limit = p.max_points(kind)
    what = "pairs" if kind == "W" else "angles"
    if n < 2:
        raise LimitError(f"a {kind} table needs at least 2 {what}, got {n}")
    if n > limit:
        raise LimitError(f"{kind} table has {n} {what} but {p.name} holds at most {limit}; "
                         f"use a longer interval or chained tables")
    az = np.asarray(table.az_deg)
    az_max = p.az_max_deg(kind)
    if not np.all(np.equal(np.mod(az, 1), 0)) or az.min() < 0 or az.max() > az_max:
        bad = az[(az < 0) | (az > az_max) | (np.mod(az, 1) != 0)]
        raise LimitError(f"{kind} table azimuth {bad[0]!r} is outside whole degrees "
                         f"000-{az_max:03d} accepted by {p.name}")
    if kind == "W":
        if table.el_deg is None or len(table.el_deg) != n:
            raise LimitError("a W table needs one elevation per azimuth")
        el = np.asarray(table.el_deg)
        if not np.all(np.equal(np.mod(el, 1), 0)) or el.min() < 0 or el.max() > p.el_max_deg:
            bad = el[(el < 0) | (el > p.el_max_deg) | (np.mod(el, 1) != 0)]
            raise LimitError(f"W table elevation {bad[0]!r} is outside whole degrees "
                             f"000-{p.el_max_deg:03d} accepted by {p.name}")
    if p.max_line_chars:
        per_line = (p.max_line_chars - 4) // _chars_per_point(kind)
        longest = 4 + _chars_per_point(kind) * min(n, per_line)
        if longest > p.max_line_chars:  # pragma: no cover - per_line guarantees it
            raise LimitError(f"{kind} line of {longest} characters exceeds {p.name}'s "
                             f"{p.max_line_chars}")


# Program: the whole pass -----------------------------------------------------------------


@dataclass(frozen=True)
class Prediction:
    max_error_deg: float
    mean_error_deg: float
    motor_starts: int
    t_s: np.ndarray
    error_deg: np.ndarray
    ant_az_deg: np.ndarray
    ant_el_deg: np.ndarray | None


@dataclass(frozen=True)
class StepProgram:
    """A pass compiled into one or more chained tables plus the predicted pointing."""

    tables: tuple[StepTable, ...]
    kind: str
    interval_s: int
    period_s: float
    profile: TableProfile
    spec: RotatorSpec
    prediction: Prediction
    pass_start_t_s: float
    pass_end_t_s: float
    chain_gaps_s: tuple[float, ...] = ()
    meta: dict = field(default_factory=dict, compare=False)

    @property
    def points(self) -> int:
        # Chained tables share no points: each starts with the one due at its boundary.
        return sum(len(t) for t in self.tables)

    def lines(self) -> list[str]:
        return [line for table in self.tables for line in table.lines()]

    def summary(self) -> str:
        p = self.prediction
        chain = ""
        if len(self.tables) > 1:
            chain = (f", {len(self.tables)} chained tables (host busy "
                     f"{max(self.chain_gaps_s):.2f} s at each boundary)")
        return (f"{self.kind} table on {self.profile.name}: interval {self.interval_s:03d} "
                f"(steps every {self.period_s:g} s), {self.points} points{chain}; predicted "
                f"error max {p.max_error_deg:.2f} deg, mean {p.mean_error_deg:.2f} deg, "
                f"{p.motor_starts} motor starts")


def check_tables_fit(tables: Sequence[StepTable], spec: RotatorSpec, station: Station,
                     source: str = "the plan") -> None:
    """Refuse (LimitError) tables with a point outside ``spec``'s travel or below the
    station's horizon mask: a plan file may have been made for another rotator or station."""
    from tracker.geometry import boresight_horizon_ok

    for n, table in enumerate(tables, 1):
        wire = np.asarray(table.az_deg, dtype=float)
        m = spec.frame.mech_of_wire(wire)
        el = None if table.el_deg is None else np.asarray(table.el_deg, dtype=float)
        bad = m > spec.az_span_deg + 1e-9
        why = f"beyond {spec.name}'s {spec.az_span_deg:g} deg azimuth travel"
        if el is not None and spec.has_elevation:
            el_bad = (el < spec.el_min_deg - 1e-9) | (el > spec.el_top_deg + 1e-9)
            if el_bad.any() and not bad.any():
                bad, why = el_bad, (f"outside {spec.name}'s elevation range "
                                    f"{spec.el_min_deg:g}-{spec.el_max_deg:g} deg")
            if not bad.any():
                bad = ~boresight_horizon_ok(spec, station, m, el)
                why = f"below the horizon mask of station {station.name}"
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            point = f"{int(wire[k]):03d}" + ("" if el is None else f" {int(el[k]):03d}")
            raise with_advice(LimitError,
                              f"{source}: table {n} point {k + 1} ({point}) is {why}",
                              f"; make a new plan for this rotator and station ({MAKE_PLAN})")


def compile_program(path: MountPath, spec: RotatorSpec, profile: TableProfile | str, *,
                    interval_s: int | None = None, max_error_deg: float | None = None,
                    start_az_deg: float | None = None, start_el_deg: float | None = None,
                    station: Station | None = None, baud: int = 9600,
                    meta: dict | None = None) -> StepProgram:
    """Compile ``path`` into chained-as-needed tables.

    ``interval_s`` is the ``sss`` sent (K3NG steps every ``sss + 1`` s). With
    ``max_error_deg`` the largest interval whose predicted max error stays within it is
    chosen; with neither, the smallest interval whose points fit one table. ``start_*`` is
    where the antenna is now (mechanical; default: park) to time the pre-position.
    ``station`` (optional) keeps every point above its horizon mask.
    """
    if isinstance(profile, str):
        profile = table_profile(profile)
    kind = "W" if spec.has_elevation else "M"
    if path.el_deg is None and kind == "W":
        raise ConfigError("an az/el rotator needs a path with elevations")
    if len(path.t_s) < 2:
        raise ConfigError("the path needs at least two samples (a pass of zero length?)")
    if interval_s is not None and max_error_deg is not None:
        raise ConfigError("give either an interval or a max error, not both")
    extra = profile.period_extra_s
    duration = float(path.t_s[-1] - path.t_s[0])
    common: dict[str, Any] = dict(
        spec=spec, profile=profile, kind=kind, start_az_deg=start_az_deg,
        start_el_deg=start_el_deg, station=station, baud=baud, meta=meta or {})
    if interval_s is not None:
        if not (INTERVAL_MIN_S <= int(interval_s) <= INTERVAL_MAX_S):
            raise ConfigError(f"interval {interval_s} s is invalid; allowed: "
                              f"{INTERVAL_MIN_S}-{INTERVAL_MAX_S} whole seconds")
        return _compile_at(path, int(interval_s), **common)
    if max_error_deg is not None:
        return _compile_within(path, max_error_deg, _interval_candidates(duration, extra),
                               common)
    cap = profile.max_points(kind)
    for sss in range(INTERVAL_MIN_S, INTERVAL_MAX_S + 1):
        if _n_points(duration, sss + extra) <= cap:
            return _compile_at(path, sss, **common)
    return _compile_at(path, INTERVAL_MAX_S, **common)


def _compile_within(path: MountPath, max_error_deg: float, candidates: list[int],
                    common: dict) -> StepProgram:
    """The first of ``candidates`` (largest first) whose predicted error is within
    ``max_error_deg``; LimitError naming the best one when none is."""
    if not (max_error_deg > 0):
        raise ConfigError(f"max error {max_error_deg} deg is invalid; give a value > 0")
    best: StepProgram | None = None
    for sss in candidates:
        prog = _compile_at(path, sss, **common)
        if prog.prediction.max_error_deg <= max_error_deg:
            return prog
        if best is None or prog.prediction.max_error_deg < best.prediction.max_error_deg:
            best = prog
    assert best is not None
    raise with_advice(LimitError,
                      f"no interval keeps the predicted error within {max_error_deg:g} deg; "
                      f"the best is {best.prediction.max_error_deg:.2f} deg at interval "
                      f"{best.interval_s} s", ". Raise max_error_deg or give interval_s")


def _interval_candidates(duration_s: float, extra: int) -> list[int]:
    """Intervals to try for ``max_error_deg``, largest first (the pass needs >= 2 steps)."""
    base = [*range(1, 31), 35, 40, 45, 50, 60, 75, 90, 120, 150, 180, 240, 300, 420, 600,
            900, 999]
    useful = [s for s in base if s + extra <= max(duration_s / 2.0, 1.0 + extra)]
    return sorted(set(useful or [INTERVAL_MIN_S]), reverse=True)


def _n_points(duration_s: float, period_s: float) -> int:
    # Point 1 holds until T at AOS + period/2; the last window must reach LOS.
    return max(2, 1 + math.ceil((duration_s - period_s / 2.0) / period_s - 1e-9))


def _compile_at(path: MountPath, sss: int, *, spec: RotatorSpec, profile: TableProfile,
                kind: str, start_az_deg: float | None, start_el_deg: float | None,
                station: Station | None, baud: int, meta: dict) -> StepProgram:
    period = float(profile.period_s(sss))
    t0, t1 = float(path.t_s[0]), float(path.t_s[-1])
    n = _n_points(t1 - t0, period)
    t_start = t0 + period / 2.0
    cmd_t = t_start + (np.arange(n) - 1.0) * period
    # Point 0 holds from arrival until T; it only matters from AOS on.
    win0 = np.maximum(cmd_t, t0)
    win0[0] = t0
    win1 = np.minimum(cmd_t + period, t1)
    win1[0] = t_start
    az_m, el = _choose_points(path, spec, profile, kind, cmd_t, win0, win1, station)

    # Chaining: split into tables of at most `cap` points, never leaving a 1-point table.
    cap = profile.max_points(kind)
    bounds = list(range(0, n, cap))
    if len(bounds) > 1 and n - bounds[-1] < 2:
        bounds[-1] = n - 2
    bounds.append(n)
    az_wire = np.rint(spec.frame.wire_of(az_m)).astype(int)
    el_wire = None if el is None else np.rint(el).astype(int)
    tables: list[StepTable] = []
    gaps: list[float] = []
    for k in range(len(bounds) - 1):
        lo, hi = bounds[k], bounds[k + 1]
        tab = StepTable(kind, sss, period, az_wire[lo:hi],
                        None if el_wire is None else el_wire[lo:hi], 0.0, 0.0,
                        float(cmd_t[lo + 1]), profile)
        wire_s = tab.wire_time_s(baud)
        if k == 0:
            arrive = t0 - _preposition_s(spec, az_m[0], None if el is None else el[0],
                                         start_az_deg, start_el_deg) - PREPOSITION_MARGIN_S
        else:
            arrive = float(cmd_t[lo])
            gaps.append(wire_s)
        tables.append(replace(tab, upload_t_s=arrive - wire_s, arrive_t_s=arrive))
        tables[-1].lines()  # validate every table now, before anything can be sent
    cmd_all = cmd_t.copy()
    cmd_all[0] = tables[0].arrive_t_s
    prediction = predict(path, spec, cmd_all, az_m, el, start_az_deg, start_el_deg)
    return StepProgram(tuple(tables), kind, sss, period, profile, spec, prediction, t0, t1,
                       tuple(gaps), dict(meta))


def _preposition_s(spec: RotatorSpec, az_m: float, el: float | None,
                   start_az_deg: float | None, start_el_deg: float | None) -> float:
    az0 = spec.park_az_deg if start_az_deg is None else start_az_deg
    el0 = spec.park_el_deg if start_el_deg is None else start_el_deg
    return slew_s(spec, az0, el0, az_m, el)


# Point choice (vectorised over windows x candidates x samples) ----------------------------


_FRACTIONS = np.array([0.3, 0.5, 0.65, 0.8, 0.95])


def _choose_points(path: MountPath, spec: RotatorSpec, profile: TableProfile, kind: str,
                   cmd_t: np.ndarray, win0: np.ndarray, win1: np.ndarray,
                   station: Station | None) -> tuple[np.ndarray, np.ndarray | None]:
    n = len(cmd_t)
    span = max(float(np.max(win1 - win0)), 1e-3)
    ns = int(np.clip(math.ceil(span / min(1.0, span / 4.0)) + 1, 3, 61))
    frac = np.linspace(0.0, 1.0, ns)
    ts = win0[:, None] + (win1 - win0)[:, None] * frac[None, :]          # (n, ns)
    target = path.target_enu(ts)                                          # (n, ns, 3)

    tf = win0[:, None] + (win1 - win0)[:, None] * _FRACTIONS[None, :]    # (n, f)
    az_f, el_f = path.mount_at(tf)
    az_lo, az_hi = 0.0, float(min(spec.az_span_deg, _mech_limit(spec, profile, kind)))
    az_c = _candidates(az_f, az_lo, az_hi)                                # (n, ca)
    if kind == "W":
        # compile_program refuses a W table for a path without elevations
        assert el_f is not None and path.el_deg is not None
        el_hi = float(min(spec.el_top_deg, profile.el_max_deg))
        el_c = _candidates(el_f, math.ceil(spec.el_min_deg), math.floor(el_hi))
    else:
        el_c = None

    # Pass 1 assumes the previous point is the rounded path at its window centre; pass 2
    # uses the pass-1 choices, so each window sees the slew it will really get.
    prev_az = np.rint(np.interp(np.r_[cmd_t[0], cmd_t[:-1]], path.t_s, path.az_m_deg))
    prev_el = None
    if kind == "W" and path.el_deg is not None:
        prev_el = np.rint(np.interp(np.r_[cmd_t[0], cmd_t[:-1]], path.t_s, path.el_deg))
    for _ in range(2):
        az_pick, el_pick = _score_blocks(spec, kind, cmd_t, ts, target, az_c, el_c, prev_az,
                                         prev_el)
        prev_az = np.r_[az_pick[0], az_pick[:-1]]
        prev_el = None if el_pick is None else np.r_[el_pick[0], el_pick[:-1]]
    if station is not None and el_pick is not None:
        el_pick = raise_to_mask(spec, station, az_pick, el_pick, step_deg=1.0)
    assert len(az_pick) == n
    return az_pick.astype(float), None if el_pick is None else el_pick.astype(float)


def _table_rotator(spec: RotatorSpec, profile: TableProfile) -> RotatorSpec:
    """``spec`` narrowed to the azimuth its tables can hold: a K3NG takes W azimuths up to 360
    only, so a 450 deg rotator's pass is planned without the overlap (a flip or an unwind)
    instead of planned in it and clipped to 360 point by point."""
    kind = "W" if spec.has_elevation else "M"
    top = _mech_limit(spec, profile, kind)
    if top >= spec.az_span_deg or top < 360.0:
        return spec     # nothing to narrow, or only the last step (the compiler's clamp)
    return spec.with_(az_span_deg=top, park_az_deg=min(spec.park_az_deg, top))


def _mech_limit(spec: RotatorSpec, profile: TableProfile, kind: str) -> float:
    if spec.controller_maps_south:
        return spec.frame.top_command_deg(spec.resolution_deg)
    return float(profile.az_max_deg(kind))


def _candidates(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Integer candidates per window: the rounded path at several window fractions ±1."""
    r = np.rint(values)
    mid = r[:, [1, 3]]
    c = np.concatenate([r, mid - 1.0, mid + 1.0], axis=1)
    return np.clip(c, lo, hi)


def _score_blocks(spec: RotatorSpec, kind: str, cmd_t: np.ndarray, ts: np.ndarray,
                  target: np.ndarray, az_c: np.ndarray, el_c: np.ndarray | None,
                  prev_az: np.ndarray, prev_el: np.ndarray | None,
                  block: int = 256) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`_score` over blocks of windows, to bound memory on 1900-point tables."""
    az_out, el_out = [], []
    for lo in range(0, len(cmd_t), block):
        s = slice(lo, lo + block)
        a, e = _score(spec, kind, cmd_t[s], ts[s], target[s], az_c[s],
                      None if el_c is None else el_c[s], prev_az[s],
                      None if prev_el is None else prev_el[s])
        az_out.append(a)
        el_out.append(e)
    return np.concatenate(az_out), None if el_c is None else np.concatenate(el_out)


def _score(spec, kind, cmd_t, ts, target, az_c, el_c, prev_az, prev_el):
    dt = np.maximum(ts - cmd_t[:, None], 0.0)                             # (n, ns)
    az_pos = move_from_rest(prev_az[:, None, None], az_c[:, :, None], dt[:, None, :],
                            spec.az_rate_deg_s, spec.start_delay_s)       # (n, ca, ns)
    if kind == "W":
        el_pos = move_from_rest(prev_el[:, None, None], el_c[:, :, None], dt[:, None, :],
                                spec.el_rate, spec.start_delay_s)         # (n, ce, ns)
        b_az, b_el = np.broadcast_arrays(az_pos[:, :, None, :], el_pos[:, None, :, :])
        err = pointing_error_deg(spec, b_az, b_el,
                                 target[:, None, None, :, :])            # (n, ca, ce, ns)
    else:
        err = pointing_error_deg(spec, az_pos, None,
                                 target[:, None, :, :])[:, :, None, :]   # (n, ca, 1, ns)
    score = err.max(axis=-1) + 0.1 * err.mean(axis=-1)                   # (n, ca, ce)
    flat = score.reshape(len(cmd_t), -1).argmin(axis=1)
    ia, ie = np.unravel_index(flat, score.shape[1:])
    rows = np.arange(len(cmd_t))
    az_pick = az_c[rows, ia]
    el_pick = el_c[rows, ie] if kind == "W" else None
    return az_pick, el_pick


# Prediction with THE motor model ---------------------------------------------------------


def predict(path: MountPath, spec: RotatorSpec, cmd_t_s: ArrayLike,
            az_m: Sequence[float] | np.ndarray, el: Sequence[float] | np.ndarray | None,
            start_az_deg: float | None = None, start_el_deg: float | None = None,
            step_s: float = 0.25) -> Prediction:
    """Drive :class:`tracker.mount.MotorModel` through the schedule; error vs the target.

    ``az_m`` is mechanical. Samples cover the pass (first to last path time).
    """
    cmd_t_s = np.asarray(cmd_t_s, dtype=float)
    t0, t1 = float(path.t_s[0]), float(path.t_s[-1])
    t_eval = np.arange(t0, t1 + 1e-9, step_s)
    motor = MotorModel(spec, az_deg=start_az_deg, el_deg=start_el_deg,
                       t_s=min(float(cmd_t_s[0]), t0))
    # A table has few points: stepping each through the motor counts every start exactly.
    az_pos, starts = drive_axis(motor.az, cmd_t_s, az_m, t_eval, closed_form=False)
    el_pos = None
    if motor.el is not None and el is not None:
        el_pos, el_starts = drive_axis(motor.el, cmd_t_s, el, t_eval, closed_form=False)
        starts += el_starts
    err = pointing_error_deg(spec, az_pos, el_pos, path.target_enu(t_eval))
    return Prediction(float(err.max()), float(err.mean()), int(starts), t_eval, err, az_pos,
                      el_pos)


# Plan files ------------------------------------------------------------------------------


def _iso(t_s: float) -> str:
    return datetime.fromtimestamp(t_s, timezone.utc).isoformat(timespec="milliseconds"
                                                               ).replace("+00:00", "Z")


def _parse_iso(text: str) -> float:
    s = text.strip()
    if s.endswith("Z"):
        s = s[:-1] + "+00:00"
    t = datetime.fromisoformat(s)
    if t.tzinfo is None:
        t = t.replace(tzinfo=timezone.utc)
    return t.timestamp()


def format_plan_file(program: StepProgram, header: dict | None = None) -> str:
    """A commented header (station, target, element epoch, T time, interval, predicted
    error) followed by, per table, its exact command lines and the ``T`` line."""
    p = program.prediction
    info = {**program.meta, **(header or {})}
    out = ["# tracker step table (GS-232 long form). Lines starting with # are comments;",
           "# every other line is sent as is, followed by CR. Send T at t_utc.",
           f"# profile: {program.profile.name}",
           f"# rotator: {program.spec.name}"]
    for key in ("station", "target", "element_epoch", "mode"):
        if key in info:
            out.append(f"# {key}: {info[key]}")
    out += [f"# interval_s: {program.interval_s} (steps every {program.period_s:g} s)",
            f"# pass: {_iso(program.pass_start_t_s)} .. {_iso(program.pass_end_t_s)}",
            f"# predicted_error_deg: max {p.max_error_deg:.2f} mean {p.mean_error_deg:.2f}",
            f"# motor_starts: {p.motor_starts}",
            f"# t_utc: {_iso(program.tables[0].start_t_s)}"]
    for k, table in enumerate(program.tables, 1):
        out.append(f"# table {k}/{len(program.tables)} points={len(table)} "
                   f"upload_utc={_iso(table.upload_t_s)} arrive_utc={_iso(table.arrive_t_s)} "
                   f"t_utc={_iso(table.start_t_s)}")
        out += table.lines()
        out.append("T")
    return "\n".join(out) + "\n"


def write_plan_file(program: StepProgram, path: str | Path, header: dict | None = None, *,
                    force: bool = False, label: str = "") -> Path:
    """Write the plan file with :func:`tracker.files.write_atomic` (an existing file only
    with ``force``; never half-written)."""
    from tracker.files import write_atomic

    return write_atomic(path, format_plan_file(program, header), force=force, label=label)


@dataclass(frozen=True)
class PlanFile:
    tables: tuple[StepTable, ...]
    header: dict


def read_plan_text(path: str | Path) -> str:
    """The text of a plan file (a regular, bounded UTF-8 file; ConfigError otherwise)."""
    return read_text_file(path, "plan file", ConfigError,
                          hint="a plan file holds '# table' headers and W/M lines")


def read_plan_file(path: str | Path) -> PlanFile:
    """Read a plan file back into tables (raises ConfigError naming file:line)."""
    path = Path(path)
    text = read_plan_text(path)
    header: dict = {}
    profile = None
    tables: list[StepTable] = []
    cur: dict | None = None
    for no, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        where = f"{path}:{no}"
        if not line:
            continue
        if line.startswith("#"):
            body = line[1:].strip()
            if body.startswith("table "):
                fields = dict(f.split("=", 1) for f in body.split()[2:] if "=" in f)
                try:
                    cur = {"upload": _parse_iso(fields["upload_utc"]),
                           "arrive": _parse_iso(fields["arrive_utc"]),
                           "start": _parse_iso(fields["t_utc"]), "lines": []}
                except (KeyError, ValueError):
                    raise ConfigError(f"{where}: table header needs upload_utc=, arrive_utc= "
                                      f"and t_utc= ISO times, got {body!r}") from None
            elif ":" in body:
                key, value = body.split(":", 1)
                header[key.strip()] = value.strip()
            continue
        if profile is None:
            profile = table_profile(header.get("profile", "gs232b"))
        if cur is None:
            raise ConfigError(f"{where}: command line before any '# table' header")
        if line.upper() == "T":
            tables.append(_table_from_lines(cur, profile, path, no))
            cur = None
            continue
        cur["lines"].append((no, line))
    if cur is not None:
        raise ConfigError(f"{path}: the last table has no T line (file cut short?)")
    if not tables:
        raise with_advice(ConfigError, f"{path}: no tables found", f"; write one with {MAKE_PLAN}")
    _check_header_agrees(path, header, tables[0])
    return PlanFile(tuple(tables), header)


def _check_header_agrees(path: Path, header: dict, first: StepTable) -> None:
    """The header's interval and T time are written from the tables; one that disagrees
    with them is a file edited by hand or damaged, and which of the two to trust is a guess."""
    interval = header.get("interval_s", "").split(" ", 1)[0]
    if interval and interval != str(first.interval_s):
        raise with_advice(ConfigError, f"{path}: the header says interval_s {interval} but the "
                          f"tables step every {first.interval_s:03d}",
                          f"; regenerate the file with {MAKE_PLAN}")
    t_text = header.get("t_utc", "")
    try:
        t_ok = not t_text or abs(_parse_iso(t_text) - first.start_t_s) < 1.0
    except (ValueError, OverflowError):
        t_ok = False
    if not t_ok:
        raise with_advice(ConfigError, f"{path}: the header says t_utc {t_text} but the first "
                          f"table's T time is {_iso(first.start_t_s)}",
                          f"; regenerate the file with {MAKE_PLAN}")


def _table_from_lines(cur: dict, profile: TableProfile, path: Path, t_no: int
                      ) -> StepTable:
    kinds, intervals, az_list, el_list = set(), set(), [], []
    where = f"{path}:{t_no}"
    for no, line in cur["lines"]:
        try:
            decoded = decode_table_line(line)
        except ValueError:
            raise ConfigError(f"{path}:{no}: not a long-form W/M line: {line[:40]!r}; expected "
                              f"'Wsss aaa eee ...' or 'Msss aaa ...' with 3-digit numbers"
                              ) from None
        kinds.add(decoded.kind)
        intervals.add(decoded.interval_s)
        az_list += decoded.az
        el_list += decoded.el or []
    if len(kinds) != 1 or len(intervals) != 1:
        raise ConfigError(f"{where}: a table mixes W/M or intervals")
    kind, sss = kinds.pop(), intervals.pop()
    az, el = np.array(az_list), (np.array(el_list) if kind == "W" else None)
    table = StepTable(kind, sss, float(profile.period_s(sss)), az, el, cur["upload"],
                      cur["arrive"], cur["start"], profile)
    if table.lines() != [line for _, line in cur["lines"]]:
        raise with_advice(ConfigError, f"{where}: table lines are not in the controller's "
                          f"exact format", f" (regenerate the file with {MAKE_PLAN})")
    return table


def tables_from_points(kind: str, interval_s: int, points: Sequence, profile: TableProfile,
                       start_t_s: float = 0.0) -> StepTable:
    """A table from raw points (tests, hand-made tables); validated on encode."""
    if kind == "W":
        az = np.array([p[0] for p in points])
        el = np.array([p[1] for p in points])
    else:
        az, el = np.array(list(points)), None
    period = float(profile.period_s(interval_s))
    return StepTable(kind, interval_s, period, az, el, start_t_s - 1.0, start_t_s - 1.0,
                     start_t_s, profile)


# From a pass -----------------------------------------------------------------------------


def compile_pass(track: SkyTrack, spec: RotatorSpec, station: Station,
                 profile: TableProfile | str, *,
                 current: tuple[float, float] | None = None, interval_s: int | None = None,
                 max_error_deg: float | None = None, baud: int = 9600,
                 meta: dict | None = None) -> StepProgram:
    """Plan the mount path for ``track`` with the planner, then compile it.

    The planner chooses the mode (normal / overlap / flip / keyhole / unwind / ahead); it
    runs without command lead because the compiler places each point for its own hold
    window. Only the visible part of the track (AOS..LOS against the mask) becomes table
    points.
    """
    from tracker.planner import plan_pass

    if isinstance(profile, str):
        profile = table_profile(profile)
    spec = _table_rotator(spec, profile)
    plan = plan_pass(track, spec, station, current, lead_s=0.0)
    vis = np.flatnonzero(np.asarray(plan.visible))
    if len(vis) < 2:
        raise ConfigError(f"{getattr(track, 'name', 'the target')} is not above the horizon "
                          f"mask long enough to make a table")
    sl = slice(int(vis[0]), int(vis[-1]) + 1)
    t = np.asarray(plan.t_s, dtype=float)[sl]
    taz, tel = track.direction_at(t)
    el = np.asarray(plan.cmd_el_deg, dtype=float)[sl] if spec.has_elevation else None
    path = MountPath(t, np.asarray(plan.cmd_az_deg, dtype=float)[sl], el,
                     float(spec.stop_bearing_deg), azel_to_enu(taz, tel),
                     getattr(track, "name", ""), {"mode": plan.mode})
    start_az, start_el = current if current is not None else (None, None)
    info = {"mode": plan.mode, **(meta or {})}
    return compile_program(path, spec, profile, interval_s=interval_s,
                           max_error_deg=max_error_deg, start_az_deg=start_az,
                           start_el_deg=start_el, station=station, baud=baud, meta=info)
