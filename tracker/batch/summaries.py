"""The sky track of one batch pass, and the planner's summary of the passes worth planning."""

from __future__ import annotations

import math

import numpy as np

from tracker.batch.finder import PassTable
from tracker.batch.geometry import look_angles, teme_to_ecef
from tracker.skytrack import SkyTrack
from tracker.station import Station


def pass_track(satrec, station: Station, aos_s: float, los_s: float, step_s: float = 5.0,
               name: str = "") -> SkyTrack:
    """The sky track of one pass (az/el every ``step_s`` from AOS to LOS, both included)."""
    from sgp4.api import jday

    from tracker.batch.geometry import StationFrames, gmst_rad

    n = max(2, math.ceil((los_s - aos_s) / step_s) + 1)
    t = np.linspace(aos_s, los_s, n)
    jd0, fr0 = jday(1970, 1, 1, 0, 0, 0.0)
    fr = fr0 + t / 86400.0
    err, r, v = satrec.sgp4_array(np.full(n, jd0), fr)
    r_ecef, v_ecef = teme_to_ecef(r, v, gmst_rad(jd0, fr))
    el, az, _ = look_angles(r_ecef, v_ecef, StationFrames.from_stations([station]), 0)
    ok = (err == 0) & np.isfinite(el)
    return SkyTrack.from_azel(t[ok], az[ok], el[ok], name=name)


def plan_summaries(table: PassTable, satrecs, spec, min_max_el_deg: float = 0.0,
                   step_s: float = 5.0, on_plan=None) -> list[dict | None]:
    """The planner's summary for each pass whose max elevation reaches ``min_max_el_deg``
    (``None`` for the others and for clipped passes): mode, max error, pre-position time.

    ``on_plan(index, plan, station)`` is called with each MountPlan (e.g. to draw it)."""
    from tracker.planner import plan_pass

    out: list[dict | None] = []
    for row in table.passes:
        if row["max_el_deg"] < min_max_el_deg or row["aos_clipped"] or row["los_clipped"]:
            out.append(None)
            continue
        station = table.stations[int(row["station"])]
        track = pass_track(satrecs[int(row["sat"])], station, float(row["aos_s"]),
                           float(row["los_s"]), step_s, table.names[int(row["sat"])])
        if len(track) < 2:
            out.append(None)
            continue
        plan = plan_pass(track, spec, station)
        if on_plan is not None:
            on_plan(len(out), plan, station)
        out.append({"mode": plan.mode, "max_error_deg": round(float(plan.max_error_deg), 2),
                    "preposition_s": float(plan.preposition_t_s),
                    "reason": plan.reason})
    return out
