"""EME session: tonight's Moon from your station — rise/transit/set, 60 s track, mount plan.

    python examples/eme_moon_night.py --lat 52.81 --lon 6.40 --at 2026-08-22T12:00Z
    python examples/eme_moon_night.py --lat -33.87 --lon 151.21 --rotator G-5400B --min-el 5

Without ``--at`` it uses the current time. "Tonight" is the next Moon pass that is up at or
after that time (searched over 36 h). Then the planner's summary for the rotator and the
GS-232B step table (one ``W`` point every 60 s): the Moon at 60 s steps fits one 1900-pair
table. Everything comes from :mod:`tracker.api`.
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta, timezone

import numpy as np

from tracker.api import (
    ManualClock,
    MountPath,
    Station,
    SystemClock,
    TrackerError,
    compile_program,
    event_labels,
    find_passes,
    plan_pass,
    preset,
    resolve_target,
)

STEP_S = 60.0
TABLE_PAIRS = 1900  # GS-232A/B long-form W table limit


def _az(az_deg: float) -> float:
    return round(float(az_deg), 1) % 360.0  # 359.99 prints as 0.0, not 360.0


def _utc(t_s: float) -> str:
    return datetime.fromtimestamp(t_s, timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")


def _times(t0_s: float, t1_s: float, step_s: float) -> np.ndarray:
    """Sample times from t0 to t1 every ``step_s`` (t1 always included)."""
    t = np.arange(t0_s, t1_s, step_s)
    return np.append(t, t1_s) if t.size == 0 or t[-1] < t1_s else t


def _parse_at(text: str) -> datetime:
    t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return t if t.tzinfo else t.replace(tzinfo=timezone.utc)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lat", type=float, default=52.81, help="latitude, deg north")
    ap.add_argument("--lon", type=float, default=6.40, help="longitude, deg east")
    ap.add_argument("--alt", type=float, default=0.0, help="altitude, m")
    ap.add_argument("--min-el", type=float, default=0.0, help="minimum elevation, deg")
    ap.add_argument("--at", help="UTC start time (default: now), e.g. 2026-08-22T12:00Z")
    ap.add_argument("--rotator", default="G-5500", help="rotator preset for the plan")
    ap.add_argument("--rows", type=int, default=8, help="track rows to print (0 = all)")
    args = ap.parse_args(argv)
    clock = ManualClock(_parse_at(args.at)) if args.at else SystemClock()
    try:
        return _session(args, clock.now())
    except TrackerError as e:
        print(f"eme_moon_night: error: {e}", file=sys.stderr)
        return 2


def _session(args, now: datetime) -> int:
    station = Station("station", args.lat, args.lon, args.alt, args.min_el)
    moon = resolve_target("moon")
    passes = find_passes(moon, station, now, now + timedelta(hours=36))
    if not passes:
        print(f"The Moon does not rise above {args.min_el:g}° at {args.lat}, {args.lon} in the "
              f"36 h from {_utc(now.timestamp())}.")
        return 0
    p = passes[0]
    rise, transit, set_ = event_labels(moon.kind)
    # A Moon already up: track it from now (its real rise, in the past, is printed).
    start_s = max(p.aos.timestamp(), now.timestamp())
    print(f"Moon from {args.lat:.4f}, {args.lon:.4f} (min el {args.min_el:g}°, "
          "no refraction)")
    print(f"  {rise:<8} {_utc(p.aos.timestamp())}  az {_az(p.aos_az_deg):6.1f}°"
          + ("  (already up)" if p.in_progress_at_start else ""))
    print(f"  {transit:<8} {_utc(p.tca.timestamp())}  az {_az(p.tca_az_deg):6.1f}°  "
          f"el {p.max_el_deg:5.1f}°")
    print(f"  {set_:<8} {_utc(p.los.timestamp())}  az {_az(p.los_az_deg):6.1f}°"
          + ("" if p.los_known else "  (still up at the end of the search)"))
    track = moon.observe(station, _times(start_s, p.los.timestamp(), STEP_S))
    duration_s = p.los.timestamp() - start_s
    fits = "fits" if len(track) <= TABLE_PAIRS else "does NOT fit"
    print(f"Track: {len(track)} points at {STEP_S:g} s ({duration_s / 3600:.1f} h) — "
          f"{fits} one {TABLE_PAIRS}-pair step table")
    print(f"  range {np.nanmin(track.range_km):,.0f} .. {np.nanmax(track.range_km):,.0f} km, "
          f"EME path loss varies by {_path_loss_span_db(track.range_km):.2f} dB")
    rows = range(len(track)) if args.rows == 0 else np.unique(
        np.linspace(0, len(track) - 1, max(args.rows, 2)).round().astype(int))
    print("  UTC                       az_deg  el_deg   range_km  rate_km_s")
    for i in rows:
        el_deg = round(float(track.el_deg[i]), 1) + 0.0  # no "-0.0" at rise
        print(f"  {_utc(track.t_s[i])}  {_az(track.az_deg[i]):6.1f}  {el_deg:6.1f}  "
              f"{track.range_km[i]:9.0f}  {track.range_rate_km_s[i]:+9.4f}")
    _plan(track, station, args.rotator)
    return 0


def _path_loss_span_db(range_km: np.ndarray) -> float:
    # Radar-equation EME loss goes with range^4.
    return float(40.0 * np.log10(np.nanmax(range_km) / np.nanmin(range_km)))


def _plan(track, station: Station, rotator: str) -> None:
    spec = preset(rotator)
    plan = plan_pass(track, spec, station)
    s = plan.summary()
    print(f"Plan on {spec.name}: mode {s['mode']} ({s['reason']}); pre-position to "
          f"az {s['preposition_az_deg']:.0f}° el {s['preposition_el_deg'] + 0.0:.0f}°; "
          f"max error {s['max_error_deg']:.2f}°, lost {s['lost_track_s']:.0f} s, "
          f"travel {s['travel_deg']:.0f}°, {s['motor_starts']} motor starts")
    _step_table(plan, track, spec, station)


def _step_table(plan, track, spec, station: Station) -> None:
    path = MountPath.from_plan(plan, track, spec)
    program = compile_program(path, spec, "gs232b", interval_s=int(STEP_S), station=station)
    print(f"Step table: {program.summary()}")
    lines = program.lines()
    for line in lines[:2]:
        print(f"  {line[:76]}{'...' if len(line) > 76 else ''}")


if __name__ == "__main__":
    sys.exit(main())
