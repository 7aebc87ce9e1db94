"""Soak: back-to-back passes for many simulated hours with random faults, over a real socket.

    python benchmarks/soak.py                      # 24 simulated hours at 300x (~5 min)
    python benchmarks/soak.py --hours 2 --speed 200 --transport pty

One emulated GS-232B (G-5500 behind it) on a real TCP socket or pty, running a random fault
plan on the same SimClock as the live loop (:func:`tracker.stream.run_pass`): silent windows,
disconnects (the port closes and returns), power cycles, jams (with a repair after a while),
reply line noise and slow-reply windows. Passes are synthetic great-circle passes, one after
another. Prints passes tracked, faults injected, recoveries, lost-track seconds, errors,
commands outside the limits or below the mask (must be 0), and memory (RSS and Python heap)
at the start and the end.

Caveat (printed too): the driver's timeouts and pyserial's 0.3 s sleep when a socket closes
run on the real clock, so at N x speed a real 0.1 s costs N/10 simulated seconds; recovery
and lost-track figures are pessimistic by that much, not optimistic. The same holds for the
stall judge (about 2.5 simulated seconds without motion): at 300x that is 8 ms of real time,
so on a busy host a late emulator thread can look like a stall. Stall stops are split into
"jam in force" and "FALSE: no jam"; re-run false ones at a lower --speed before calling them
a bug.
"""

from __future__ import annotations

import argparse
import gc
import math
import random
import sys
import tempfile
import time
import tracemalloc
from collections import Counter
from datetime import datetime, timezone
from pathlib import Path

from _memory import heap_mib, rss_mib

T0_S = 1787400000.0          # 2026-08-22 UTC, the bundled element epochs


def fault_plan(rng: random.Random, hours: float, per_hour: float) -> list[str]:
    """Random faults over the run; times are emulator seconds after the start."""
    specs = ["drop=0.0005:out", "garble=0.0005:out"]      # a slightly noisy line, always
    t = 600.0
    end = hours * 3600.0
    while per_hour > 0:
        t += rng.expovariate(per_hour / 3600.0)
        if t >= end:
            break
        kind = rng.choice(["silent", "disconnect", "powercycle", "jam", "noise", "delay"])
        if kind == "silent":
            specs.append(f"silent={rng.uniform(3, 30):.1f}@{t:.1f}")
        elif kind == "disconnect":
            specs.append(f"disconnect={rng.uniform(2, 20):.1f}@{t:.1f}")
        elif kind == "powercycle":
            specs.append(f"powercycle={rng.uniform(0.5, 3):.1f}@{t:.1f}")
        elif kind == "jam":
            specs.append(f"jam={rng.choice(['az', 'el'])}:{rng.uniform(60, 300):.0f}@{t:.1f}")
        elif kind == "noise":
            specs.append(f"garble={rng.uniform(0.002, 0.02):.4f}:out@{t:.1f}+"
                         f"{rng.uniform(30, 300):.0f}")
        else:
            specs.append(f"delay={rng.uniform(0.1, 0.8):.2f}@{t:.1f}+{rng.uniform(30, 300):.0f}")
    return specs


# The soak script end to end (arguments, rig, simulated day, report); a script, read
# top to bottom.
def main(argv: list[str] | None = None) -> int:  # noqa: C901
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, default=24.0, help="simulated hours (default 24)")
    ap.add_argument("--speed", type=float, default=300.0, help="simulation speed factor")
    ap.add_argument("--seed", type=int, default=1, help="RNG seed for passes and faults")
    ap.add_argument("--faults-per-hour", type=float, default=4.0)
    ap.add_argument("--transport", choices=("tcp", "pty"), default="tcp")
    ap.add_argument("--lost-deg", type=float, default=10.0,
                    help="pointing error above which a visible second counts as lost")
    args = ap.parse_args(argv)

    from tracker.clock import SimClock
    from tracker.emulator import Gs232Controller, serve_pty, serve_tcp
    from tracker.emulator.faults import install
    from tracker.errors import StallError, TrackerError
    from tracker.mount import preset
    from tracker.planner import plan_pass
    from tracker.protocols import open_driver
    from tracker.skytrack import angular_separation_deg
    from tracker.station import HorizonMask, Station
    from tracker.stream import Link, StreamSettings, TrackCore, run_pass
    from tracker.testing import synthetic_pass

    tracemalloc.start()
    rng = random.Random(args.seed)
    spec = preset("G-5500", 50)
    station = Station("soak", 52.0, 4.4, mask=HorizonMask((0.0, 120.0, 240.0), (3.0, 8.0, 2.0)))
    clock = SimClock(datetime.fromtimestamp(T0_S, timezone.utc), args.speed)
    ctl = Gs232Controller("gs232b", spec, clock=clock, az_deg=0.0, el_deg=0.0)
    specs = fault_plan(rng, args.hours, args.faults_per_hour)
    inj = install(ctl, specs, args.seed)

    # Count every command the controller receives against the limits and the mask.
    unsafe: list[str] = []
    received = Counter()
    handle = ctl.handle_line

    def checking(line, state):
        parts = line.split()
        if line[:1] == b"W" and len(parts) == 2 and parts[0][1:].isdigit() \
                and parts[1].isdigit():
            try:
                az, el = int(parts[0][1:]), int(parts[1])
            except ValueError:
                az = el = -1
            received["W"] += 1
            look_b = (spec.bearing_of(az) + (180 if el > 90 else 0)) % 360
            look_el = 180 - el if el > 90 else el
            if not (0 <= az <= spec.az_span_deg and 0 <= el <= spec.el_max_deg) or \
                    look_el < float(station.horizon_at(look_b)) - 0.5 - 1e-9:
                unsafe.append(line.decode("ascii", "replace"))
        return handle(line, state)
    ctl.handle_line = checking

    tmp = tempfile.mkdtemp(prefix="tracker-soak-")
    server = serve_tcp(ctl) if args.transport == "tcp" else serve_pty(
        ctl, link=str(Path(tmp) / "ttyEMU0"))
    timeout_s = 0.03 if args.speed > 100 else 0.3

    def connect():
        return open_driver(server.url, "gs232b", timeout_s=timeout_s)

    end_s = T0_S + args.hours * 3600.0
    gc.collect()
    mem0, heap0 = rss_mib(), heap_mib()
    real0 = time.monotonic()
    mem_warm, heap_warm = mem0, heap0
    stats: Counter[str] = Counter()
    lost_s = 0.0
    visible_s = 0.0
    errors: Counter[str] = Counter()
    current = (0.0, 0.0)
    cursor = T0_S + 300.0
    print(f"soak: {args.hours:g} h simulated at {args.speed:g}x over {args.transport}, "
          f"{len(specs)} scheduled faults, seed {args.seed}", flush=True)
    while True:
        duration = rng.uniform(300.0, 900.0)
        aos = cursor + rng.uniform(120.0, 600.0)
        if aos + duration > end_s:
            break
        track = synthetic_pass(rng.uniform(8.0, 89.0), rng.uniform(0.0, 360.0), duration,
                               pad_s=30.0, clockwise=rng.random() < 0.5, t0_s=aos,
                               name=f"P{stats['passes'] + 1}")
        cursor = aos + duration
        if clock.timestamp() > aos - 60.0:
            stats["skipped (previous pass overran)"] += 1
            continue
        stats["passes"] += 1
        plan = plan_pass(track, spec, station, current=current)
        core = TrackCore(plan, track, spec, station, StreamSettings(deadband_deg=3.0))
        last_t = [None]
        pass_lost = [0.0]

        def on_status(st, core=core, track=track, last_t=last_t, pass_lost=pass_lost):
            nonlocal lost_s, visible_s
            if core.aos_s <= st.t_s <= core.los_s:
                dt = 0.0 if last_t[0] is None else min(st.t_s - last_t[0], 30.0)
                last_t[0] = st.t_s
                az, el = ctl.antenna()
                taz, tel = track.direction_at(st.t_s)
                if float(tel) < float(station.horizon_at(float(taz) % 360.0)):
                    return
                visible_s += dt
                err = float(angular_separation_deg(spec.bearing_of(az), el, taz, tel))
                if not math.isfinite(err) or err > args.lost_deg:
                    lost_s += dt
                    pass_lost[0] += dt

        def event(kind, **data):
            if kind == "state" and data.get("state") in ("reconnected", "port_lost", "no_reply",
                                                         "controller_off", "stall"):
                stats[f"state {data['state']}"] += 1

        try:
            res = run_pass(core, Link(connect, spec), clock, on_status=on_status, events=event)
            stats["tracked (completed)"] += int(res.completed)
            stats["reconnects (in completed passes)"] += res.reconnects
        except StallError as e:
            stats["stall stops"] += 1
            # a stall stop with no jam in force is a false alarm: count it separately
            jammed = ctl.motor.az.jammed or (ctl.motor.el is not None and ctl.motor.el.jammed)
            stats["stall stops (jam in force)" if jammed else "stall stops (FALSE: no jam)"] += 1
            if not jammed:
                print(f"  false stall stop in pass {stats['passes']}: {str(e)[:100]}", flush=True)
            # the rest of this pass is not tracked: count it as lost
            rest = max(0.0, core.los_s - max(clock.timestamp(), core.aos_s))
            lost_s += rest
            visible_s += rest
        except TrackerError as e:
            errors[f"{type(e).__name__}: {str(e)[:60]}"] += 1
        except Exception as e:   # anything else is a bug the soak must show, not hide
            errors[f"UNEXPECTED {type(e).__name__}: {str(e)[:60]}"] += 1
        az, el = ctl.antenna()
        current = (az, el if el is not None else 0.0)
        if stats["passes"] == 1:     # imports and caches are warm now: the growth baseline
            gc.collect()
            mem_warm = rss_mib()
            heap_warm = heap_mib()
        if stats["passes"] % 10 == 0:
            hrs = (clock.timestamp() - T0_S) / 3600.0
            print(f"  {hrs:5.1f} h: {stats['passes']} passes, "
                  f"{stats['tracked (completed)']} completed, lost {lost_s:.0f} s, "
                  f"RSS {rss_mib():.1f} MiB", flush=True)
    server.close()
    if server.errors:
        errors["EMULATOR " + server.errors[0][:60]] += len(server.errors)
    gc.collect()
    mem1, heap1 = rss_mib(), heap_mib()
    sim_h = (clock.timestamp() - T0_S) / 3600.0
    injected = {k: v for k, v in sorted(inj.stats.items())}
    print("\nsoak results")
    print(f"  simulated time        {sim_h:.2f} h in {time.monotonic() - real0:.0f} s real")
    for k, v in sorted(stats.items()):
        print(f"  {k:30s} {v}")
    # a recovery: the loop lost the controller (port gone or replies stopped) and got it back
    print(f"  recoveries            {stats['state reconnected']} of {stats['state port_lost']} "
          f"losses (port back, tracking resumed)")
    print(f"  faults injected       {injected}")
    timed = [sp for sp in specs if "@" in sp and "+" not in sp.split("@", 1)[1]]
    started = sum(v for k, v in inj.stats.items() if k.endswith("_events"))
    print(f"  timed faults started  {started} of {len(timed)} scheduled; "
          f"{len(specs) - len(timed)} line-noise/slow-reply windows")
    print(f"  lost-track seconds    {lost_s:.0f} of {visible_s:.0f} visible "
          f"({100 * lost_s / max(visible_s, 1):.2f} %; error > {args.lost_deg:g} deg)")
    print(f"  errors                {sum(errors.values())} {dict(errors)}")
    print(f"  W commands received   {received['W']}; outside limits or below the mask: "
          f"{len(unsafe)} {unsafe[:5]}")
    print(f"  memory RSS            start {mem0:.1f} MiB, after pass 1 {mem_warm:.1f} MiB, "
          f"end {mem1:.1f} MiB ({mem1 - mem_warm:+.1f} since pass 1)")
    print(f"  python heap (traced)  start {heap0:.2f} MiB, after pass 1 {heap_warm:.2f} MiB, "
          f"end {heap1:.2f} MiB ({heap1 - heap_warm:+.2f} since pass 1)")
    print(f"  caveat: real-clock waits (driver timeout {timeout_s} s, pyserial close 0.3 s) "
          f"cost {args.speed:g}x as much simulated time")
    return 1 if unsafe or any(k.startswith("UNEXPECTED") for k in errors) else 0


if __name__ == "__main__":
    sys.exit(main())
