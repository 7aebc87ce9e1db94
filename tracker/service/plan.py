"""The rolling schedule of a station run: which passes of the wanted targets the rotator takes.

:func:`build_rolling_schedule` finds every pass of the ``[schedule]`` targets over the next
``horizon_h`` hours (satellites with the batch finder, the Sun, Moon and other targets with
:func:`tracker.passes.find_passes`), drops the ones lower than ``min_max_el_deg``, lets the
priority selection of :mod:`tracker.pass_schedule` (counting the slew between passes and
``settle_s``) choose among the rest, and decides for each chosen pass whether it runs as a
live stream or a step table (``mode = "auto"``: a table where the compiler's predicted
max error stays within the rotator's deadband + :data:`TABLE_MARGIN_DEG`).

A recompute (fresh elements, a new day) is given the previous schedule as ``keep``: a pass
being tracked, done or failed keeps its state and stays chosen, so nothing is tracked twice
and the pass under way is never dropped; a pass still planned lends its mode decision to the
same pass in the new schedule (matched by :attr:`PlannedPass.key`), which keeps a recompute
cheap.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from tle.catalog import Catalog
from tracker.config import ScheduleSettings
from tracker.controllers import Controller
from tracker.errors import ConfigError
from tracker.mount import RotatorSpec
from tracker.passes import Pass
from tracker.station import Station
from tracker.targets import SatelliteTarget, Target
from tracker.timescale import iso_utc, to_datetime

STATES = ("planned", "tracking", "done", "skipped", "failed")
KEY_ROUND_S = 10.0        # AOS rounding of a pass key: fresher elements move AOS by seconds
LOOKBACK_S = 3600.0       # a satellite pass under way at the start began at most this early
TABLE_INTERVAL_S = 2      # the step interval the auto mode judges a table at
TABLE_MARGIN_DEG = 1.0    # a table is chosen if its predicted max error <= deadband + this
TRACK_STEP_S = 1.0        # sky track sampling of a satellite pass for the predictions
SLOW_TRACK_STEP_S = 10.0  # ... and of the Sun, Moon and other slow targets
TRACK_PAD_S = 60.0        # as `tracker upload`: the track reaches a minute past AOS/LOS
MAX_TABLE_PASS_S = 2 * 3600.0  # longer passes (the Sun's day) run as a stream
KEPT_PRIORITY = 10**6     # a kept pass outweighs any set of passes it could conflict with


def pass_key(target: Target, aos_s: float) -> str:
    """``NORAD-YYYYmmddTHHMMSSZ`` (the target's name instead of an id for the Sun, Moon ...),
    AOS rounded to :data:`KEY_ROUND_S`: stable across recomputes with fresher elements."""
    who = target.norad_id if isinstance(target, SatelliteTarget) else target.name
    aos = to_datetime(round(aos_s / KEY_ROUND_S) * KEY_ROUND_S)
    return f"{who}-{aos:%Y%m%dT%H%M%SZ}"


@dataclass
class PlannedPass:
    """One pass in the rolling schedule, with how it will be tracked and what became of it."""

    key: str
    target: Target
    pass_: Pass
    priority: int
    mode: str                     # "stream" | "table"
    mode_reason: str              # one line: why this mode
    predicted_max_error_deg: float
    state: str = "planned"        # planned | tracking | done | skipped | failed
    reason: str = ""              # why skipped / failed

    @property
    def aos_s(self) -> float:
        return self.pass_.aos.timestamp()

    @property
    def los_s(self) -> float:
        return self.pass_.los.timestamp()

    def entry(self) -> dict[str, Any]:
        """The :class:`~tracker.service.board.StatusBoard` schedule entry."""
        return {"key": self.key, "target": self.target.name,
                "aos_utc": iso_utc(self.pass_.aos), "los_utc": iso_utc(self.pass_.los),
                "max_el_deg": round(float(self.pass_.max_el_deg), 1),
                "priority": self.priority, "mode": self.mode, "state": self.state,
                "reason": self.reason}


@dataclass
class RollingSchedule:
    """``chosen``: the passes to track, AOS order (kept ones included); ``skipped``: the
    other passes of wanted targets, each with its reason."""

    computed_s: float
    chosen: list[PlannedPass] = field(default_factory=list)
    skipped: list[PlannedPass] = field(default_factory=list)

    def due(self, now_s: float) -> PlannedPass | None:
        """The first chosen pass still planned whose LOS is after ``now_s``."""
        for p in self.chosen:
            if p.state == "planned" and p.los_s > now_s:
                return p
        return None

    def entries(self) -> list[dict[str, Any]]:
        """Chosen and skipped passes, AOS order (``StatusBoard.set_schedule``)."""
        return [p.entry() for p in sorted(self.chosen + self.skipped, key=lambda p: p.aos_s)]


# What to track ---------------------------------------------------------------------------


def wanted_targets(catalog: Catalog, settings: ScheduleSettings) -> list[tuple[Target, int]]:
    """Every target the settings want, with its priority (> 0): the objects of each group,
    then the named targets (a name overrides its group's priority; 0 leaves it out).

    A name the catalogue does not know (or that is ambiguous) raises a one-line
    :class:`ConfigError` with the catalogue's suggestions.
    """
    from tracker.targets import resolve_target

    chosen: dict[Any, tuple[Target, int]] = {}
    for group, priority in settings.groups.items():
        try:
            members = catalog.group(group)
        except LookupError as e:
            raise ConfigError(f"[schedule] groups: {e}") from None
        for es in members:
            chosen[es.norad_id] = (SatelliteTarget(es), priority)
    for name, priority in settings.targets.items():
        try:
            target = resolve_target(name, catalog)
        except (LookupError, ValueError) as e:
            raise ConfigError(f"[schedule] targets: {e}") from None
        who = (target.norad_id if isinstance(target, SatelliteTarget)
               else target.name.casefold())
        chosen[who] = (target, priority)
    return [(t, p) for t, p in chosen.values() if p > 0]


# Finding the passes ----------------------------------------------------------------------


def _satellite_passes(targets: list[SatelliteTarget], station: Station, start_s: float,
                      end_s: float, *, only: bool = False) -> list[Pass]:
    """Passes with AOS before ``end_s`` and LOS after ``start_s`` (the batch finder).
    ``only``: they are all the targets, so if not one has elements usable then (a far
    ``--at``, elements years old) a :class:`PropagationError` says so, rather than an
    empty schedule that does not say why."""
    from tracker.batch import find_passes_batch, split_by_epoch

    near, _far = split_by_epoch([t.elements for t in targets], start_s - LOOKBACK_S, end_s)
    near_ids = {id(es) for es in near}  # the others' passes would look real and not be
    usable = [t for t in targets if id(t.elements) in near_ids]
    if not usable:
        if only:
            targets[0].check_span(start_s - LOOKBACK_S, end_s)
        return []
    table = find_passes_batch([t.satellite.model for t in usable], [t.name for t in usable],
                              [station], to_datetime(start_s - LOOKBACK_S),
                              to_datetime(end_s + LOOKBACK_S))
    out = []
    for row in table.passes:
        aos_s, los_s = float(row["aos_s"]), float(row["los_s"])
        if row["aos_clipped"] or row["los_clipped"] or los_s <= start_s or aos_s >= end_s:
            continue  # without a known AOS or LOS it cannot be planned; or out of the window
        target = usable[int(row["sat"])]
        out.append(Pass(
            target.name, "satellite", to_datetime(aos_s), to_datetime(float(row["tca_s"])),
            to_datetime(los_s), float(row["max_el_deg"]), float(row["aos_az_deg"]),
            float(row["tca_az_deg"]), float(row["los_az_deg"]), los_s - aos_s,
            bool(row["sunlit"]), bool(row["visible"]), in_progress_at_start=aos_s < start_s,
            target=target, station=station))
    return out


def _other_passes(target: Target, station: Station, start_s: float, end_s: float
                  ) -> list[Pass]:
    """The generic finder's passes of the Sun, Moon, a radio source ... (real AOS and LOS)."""
    from tracker.passes import find_passes

    return [p for p in find_passes(target, station, start_s, end_s)
            if p.aos_known and p.los_known and not p.always_up
            and p.aos.timestamp() < end_s and p.los.timestamp() > start_s]


def _candidates(wanted: list[tuple[Target, int]], station: Station, start_s: float,
                end_s: float) -> list[tuple[Pass, int]]:
    priority = {id(t): p for t, p in wanted}
    sats = [t for t, _p in wanted if isinstance(t, SatelliteTarget)]
    passes = (_satellite_passes(sats, station, start_s, end_s, only=len(sats) == len(wanted))
              if sats else [])
    for target, _p in wanted:
        if not isinstance(target, SatelliteTarget):
            passes += _other_passes(target, station, start_s, end_s)
    return sorted(((p, priority[id(p.target)]) for p in passes),
                  key=lambda item: item[0].aos.timestamp())


# Stream or table ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _ModeChoice:
    mode: str
    reason: str
    predicted_max_error_deg: float


def choose_mode(pass_: Pass, spec: RotatorSpec, station: Station, controller: Controller,
                mode: str) -> _ModeChoice:
    """``mode`` ("stream", "table", "auto") resolved for one pass, with the predicted max
    error of the way chosen: the planner's for a stream, the step-table compiler's (at
    :data:`TABLE_INTERVAL_S`) for a table."""
    from tracker.errors import LimitError
    from tracker.planner import plan_pass
    from tracker.steptable import compile_pass

    step_s = TRACK_STEP_S if pass_.kind == "satellite" else SLOW_TRACK_STEP_S
    track = pass_.track(step_s, pad_s=TRACK_PAD_S)
    stream_error = float(plan_pass(track, spec, station).max_error_deg)

    def stream(reason: str) -> _ModeChoice:
        return _ModeChoice("stream", reason, stream_error)

    if mode == "stream":
        return stream("mode = stream")
    if controller.step_tables is None:
        return stream("controller has no step tables")
    if pass_.duration_s > MAX_TABLE_PASS_S:
        return stream(f"a {pass_.duration_s / 3600.0:.1f} h pass is too long for step tables")
    try:
        program = compile_pass(track, spec, station, controller.step_tables,
                               interval_s=TABLE_INTERVAL_S)
    except (ConfigError, LimitError) as e:
        return stream(f"no step table: {e}")
    error = float(program.prediction.max_error_deg)
    limit = spec.deadband_deg + TABLE_MARGIN_DEG
    if mode == "table":
        return _ModeChoice("table", "mode = table", error)
    if error <= limit:
        return _ModeChoice("table", f"step table predicted max error {error:.1f} deg <= "
                                    f"{limit:.1f} deg (deadband + {TABLE_MARGIN_DEG:g})", error)
    return stream(f"step table predicted max error {error:.1f} deg > {limit:.1f} deg "
                  f"(deadband + {TABLE_MARGIN_DEG:g}); the live loop points better")


# The schedule ----------------------------------------------------------------------------


def _same_pass(a: Pass, b: Pass) -> bool:
    """One target's passes never overlap: overlapping passes of it are the same pass."""
    return (a.target_name == b.target_name and a.aos < b.los and b.aos < a.los)


def _record(label: str, p: Pass, station: Station) -> dict[str, Any]:
    return {"target": label, "station": station.name, "aos_s": p.aos.timestamp(),
            "los_s": p.los.timestamp(), "max_el_deg": float(p.max_el_deg),
            "aos_az_deg": float(p.aos_az_deg), "los_az_deg": float(p.los_az_deg)}


def _skipped(item: tuple[Pass, int], reason: str, settings: ScheduleSettings,
             controller: Controller) -> PlannedPass:
    p, priority = item
    mode = ("stream" if settings.mode == "stream" or controller.step_tables is None
            else "table")
    return PlannedPass(pass_key(p.target, p.aos.timestamp()), p.target, p, priority, mode,
                       "not resolved: the pass is skipped", math.nan, "skipped", reason)


def _lost_to(rival: PlannedPass | None) -> str:
    if rival is None:
        return "no time to slew between its neighbours"
    what = f"priority {rival.priority}" if rival.state == "planned" else rival.state
    return f"overlaps {rival.target.name} ({what})"


def build_rolling_schedule(catalog: Catalog, station: Station, spec: RotatorSpec,
                           settings: ScheduleSettings, controller: Controller,
                           start_s: float, *, keep: Iterable[PlannedPass] = ()
                           ) -> RollingSchedule:
    """The passes to track from ``start_s`` to ``start_s + horizon_h`` (see the module
    docstring). ``keep``: the previous schedule's passes; those not "planned" stay chosen
    with their state, the planned ones lend their mode decision to the same pass."""
    from tracker.pass_schedule import build_schedule

    previous = list(keep)
    kept = [p for p in previous if p.state not in ("planned", "skipped")]
    decided = {p.key: p for p in previous if p.state == "planned"}
    end_s = start_s + settings.horizon_h * 3600.0
    found = [item for item in _candidates(wanted_targets(catalog, settings), station,
                                          start_s, end_s)
             if not any(_same_pass(item[0], k.pass_) for k in kept)]
    low = [item for item in found if item[0].max_el_deg < settings.min_max_el_deg]
    high = [item for item in found if item[0].max_el_deg >= settings.min_max_el_deg]
    skipped = [_skipped(item, f"max el {item[0].max_el_deg:.1f} < "
                              f"{settings.min_max_el_deg:g}", settings, controller)
               for item in low]
    # One record per pass, labelled by index so each gets its own priority; kept passes
    # weigh more than anything they could conflict with.
    records = [_record(str(i), k.pass_, station) for i, k in enumerate(kept)]
    records += [_record(str(len(kept) + i), p, station) for i, (p, _) in enumerate(high)]
    priorities = {str(i): KEPT_PRIORITY for i in range(len(kept))}
    priorities.update({str(len(kept) + i): prio for i, (_p, prio) in enumerate(high)})
    sched = build_schedule(records, spec, priorities, default_priority=0,
                           settle_s=settings.settle_s)
    chosen: dict[int, PlannedPass] = {}
    for i in sched.chosen:
        if i >= len(kept):
            p, priority = high[i - len(kept)]
            key = pass_key(p.target, p.aos.timestamp())
            old = decided.get(key)
            choice = (_ModeChoice(old.mode, old.mode_reason, old.predicted_max_error_deg)
                      if old is not None else
                      choose_mode(p, spec, station, controller, settings.mode))
            chosen[i] = PlannedPass(key, p.target, p, priority, choice.mode, choice.reason,
                                    choice.predicted_max_error_deg)
    everyone = {**dict(enumerate(kept)), **chosen}
    for i, rival in sched.skipped.items():
        if i >= len(kept):
            skipped.append(_skipped(high[i - len(kept)], _lost_to(everyone.get(rival)),
                                    settings, controller))
    return RollingSchedule(start_s, sorted([*kept, *chosen.values()], key=lambda p: p.aos_s),
                           sorted(skipped, key=lambda p: p.aos_s))
