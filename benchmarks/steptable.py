"""Step-table benchmark: predicted vs measured pointing error per interval, motor starts,
and upload time vs wire time.

Run: ``python benchmarks/steptable.py [--passes N] [--protocol gs232b] [--no-upload]``

1. For a seeded subset of the planner benchmark's pass suite (``passsuite.pass_suite``: real
   amateur + weather passes from three stations, plus forced overhead passes), every pass is
   compiled at intervals 1, 2, 5, 10, 20, 30 s (:func:`tracker.steptable.compile_pass`, which
   runs the planner). *Measured*: the exact command lines are fed to the emulator's controller
   (its own parser, table state machine and stepping) on a ManualClock, and the emulated
   antenna is sampled every 0.25 s against the satellite. Printed per interval: predicted and
   measured max error (worst pass, and median of per-pass max), mean error, motor starts per
   pass, and the worst |measured - predicted| over the passes.
2. End to end over a real pty with a SimClock for a few passes (driver, T timing, N polls).
3. Upload of a 1900-pair W table over a pty: measured time without pacing, and with the
   driver pacing characters at 9600 baud, each against the wire time bytes*10/9600.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import pass_suite

from tracker.clock import ManualClock, SimClock
from tracker.emulator import Gs232Controller, serve_pty
from tracker.geometry import MountPath, pointing_error_deg
from tracker.mount import preset
from tracker.protocols.gs232 import Gs232Driver
from tracker.skytrack import azel_to_enu
from tracker.steptable import compile_pass, tables_from_points
from tracker.upload import TableRunner

INTERVALS = (1, 2, 5, 10, 20, 30)


def measure_on_emulator(program, path: MountPath, protocol: str, step_s: float = 0.25):
    """Feed the program's lines to the emulator's controller on a ManualClock."""
    spec = program.spec
    first = program.tables[0]
    clock = ManualClock(datetime.fromtimestamp(first.upload_t_s - 1.0, timezone.utc))
    ctrl = Gs232Controller(protocol, spec, clock=clock)
    session = ctrl.open_session()
    events = []
    for table in program.tables:
        events.append((table.arrive_t_s, table.encode()))
        events.append((table.start_t_s, b"T\r"))
    events.sort(key=lambda e: e[0])
    t_eval = np.arange(program.pass_start_t_s, program.pass_end_t_s + 1e-9, step_s)
    az = np.empty(len(t_eval))
    el = np.empty(len(t_eval))
    k = 0
    for i, t in enumerate(t_eval):
        while k < len(events) and events[k][0] <= t:
            clock.advance(events[k][0] - clock.timestamp())
            session.feed(events[k][1])
            k += 1
        clock.advance(t - clock.timestamp())
        a, e = ctrl.antenna()
        az[i], el[i] = a, (0.0 if e is None else e)
    err = pointing_error_deg(spec, az, el if spec.has_elevation else None,
                             path.target_enu(t_eval))
    return err


def section_accuracy(suite, protocol: str, rotator: str) -> None:
    spec = preset(rotator)
    print(f"\n1. Predicted vs measured (emulator state machine, ManualClock), {len(suite)} "
          f"passes, {rotator}, {protocol}")
    print(f"{'sss':>4} {'period':>6} | {'pred max':>8} {'meas max':>8} | {'pred med':>8} "
          f"{'meas med':>8} | {'pred mean':>9} {'meas mean':>9} | {'starts/pass':>11} | "
          f"{'worst |m-p|':>11} {'compile ms':>10}")
    for sss in INTERVALS:
        pmax, mmax, pmean, mmean, starts, diff = [], [], [], [], [], []
        t_comp = 0.0
        for sp in suite:
            t0 = time.perf_counter()
            try:
                prog = compile_pass(sp.track, spec, sp.station, protocol, interval_s=sss)
            except Exception as e:  # a pass too short for this interval
                print(f"  skip {sp.meta.get('target')}: {e}")
                continue
            t_comp += time.perf_counter() - t0
            path = _path_of(prog, sp.track)
            err = measure_on_emulator(prog, path, protocol)
            p = prog.prediction
            pmax.append(p.max_error_deg)
            mmax.append(float(err.max()))
            pmean.append(p.mean_error_deg)
            mmean.append(float(err.mean()))
            starts.append(p.motor_starts)
            diff.append(abs(float(err.max()) - p.max_error_deg))
        n = max(len(pmax), 1)
        print(f"{sss:>4} {prog.period_s:>6g} | {max(pmax):8.2f} {max(mmax):8.2f} | "
              f"{np.median(pmax):8.2f} {np.median(mmax):8.2f} | {np.mean(pmean):9.2f} "
              f"{np.mean(mmean):9.2f} | {np.mean(starts):11.1f} | {max(diff):11.3f} "
              f"{1000 * t_comp / n:10.1f}")


def _path_of(prog, track) -> MountPath:
    # The error is measured against the satellite over the compiled span (AOS..LOS).
    t = np.arange(prog.pass_start_t_s, prog.pass_end_t_s + 1e-9, 1.0)
    taz, tel = track.direction_at(t)
    return MountPath(t, np.zeros_like(t), np.zeros_like(t), sky_enu=azel_to_enu(taz, tel))


def section_pty(suite, protocol: str, rotator: str, speed: float) -> None:
    spec = preset(rotator)
    print(f"\n2. End to end over a real pty (driver + emulator, SimClock {speed:g}x), "
          f"interval 5 s")
    print(f"{'pass':<28} {'pred max':>8} {'meas max':>8} {'T late ms':>9} {'N polls':>7} "
          f"{'resyncs':>7} {'real s':>6}")
    for sp in suite:
        prog = compile_pass(sp.track, spec, sp.station, protocol, interval_s=5)
        path = _path_of(prog, sp.track)
        clock = SimClock(datetime.fromtimestamp(prog.tables[0].upload_t_s - 2.0,
                                                timezone.utc), speed=speed)
        ctrl = Gs232Controller(protocol, spec, clock=clock)
        samples = []
        stop = threading.Event()

        def sample(ctrl=ctrl, clock=clock, samples=samples, stop=stop):
            while not stop.is_set():
                t = clock.timestamp()
                a, e = ctrl.antenna()
                samples.append((t, a, 0.0 if e is None else e))
                time.sleep(0.005)

        th = threading.Thread(target=sample, daemon=True)
        r0 = time.perf_counter()
        with serve_pty(ctrl) as server:
            th.start()
            drv = Gs232Driver.from_url(server.url, protocol)
            drv.stop_on_exit = False
            report = TableRunner(drv, clock, poll_s=2.0).run(prog.tables)
            drv.close()
            stop.set()
            th.join()
        s = np.array(samples)
        s = s[(s[:, 0] >= path.t_s[0]) & (s[:, 0] <= path.t_s[-1])]
        err = pointing_error_deg(spec, s[:, 1], s[:, 2], path.target_enu(s[:, 0]))
        name = f"{sp.meta.get('target', '')[:14]} {sp.meta.get('max_el_deg', 0):4.0f}deg"
        print(f"{name:<28} {prog.prediction.max_error_deg:8.2f} {err.max():8.2f} "
              f"{1000 * report.t_late_s[0]:9.0f} {report.polls:7d} {len(report.resyncs):7d} "
              f"{time.perf_counter() - r0:6.1f}")


def section_upload(protocol: str) -> None:
    print("\n3. Upload of a 1900-pair W table over a pty at 9600 baud")
    table = tables_from_points("W", 1, [(i % 451, i % 181) for i in range(1900)],
                               __import__("tracker.steptable", fromlist=["PROFILES"])
                               .PROFILES["gs232b"])
    nbytes = len(table.encode())
    wire_s = nbytes * 10 / 9600
    for label, pace in (("driver, no pacing (pty has no baud)", 0.0),
                        ("driver pacing 10 bits/char at 9600", 10 / 9600)):
        ctrl = Gs232Controller(protocol)
        with serve_pty(ctrl) as server:
            drv = Gs232Driver.from_url(server.url, protocol, pace_char_s=pace)
            drv.stop_on_exit = False
            t0 = time.perf_counter()
            drv.upload_table(1, table.points)
            while ctrl.table is None and time.perf_counter() - t0 < 60:
                time.sleep(0.001)
            dt = time.perf_counter() - t0
            drv.close()
        ok = ctrl.table is not None and len(ctrl.table.points) == 1900
        print(f"  {label:<40} {nbytes} bytes: {dt:7.3f} s vs wire {wire_s:.3f} s "
              f"(ratio {dt / wire_s:.3f}), controller holds 1900: {ok}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--passes", type=int, default=30, help="suite subset size (seeded)")
    ap.add_argument("--protocol", default="gs232b")
    ap.add_argument("--rotator", default="G-5500")
    ap.add_argument("--pty-passes", type=int, default=3)
    ap.add_argument("--speed", type=float, default=40.0)
    ap.add_argument("--no-upload", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    suite = pass_suite(days=1.0, n_overhead=6)
    rng = np.random.default_rng(5)
    pick = sorted(rng.choice(len(suite), size=min(args.passes, len(suite)), replace=False))
    subset = [suite[i] for i in pick]
    # Always include some overhead (keyhole/flip) passes.
    subset += [s for s in suite if s.meta.get("kind") == "overhead"][:3]
    print(f"pass suite: {len(suite)} passes (1 day, 3 stations + overhead); using "
          f"{len(subset)} ({time.perf_counter() - t0:.1f} s to build)")
    section_accuracy(subset, args.protocol, args.rotator)
    real = [s for s in subset if s.meta.get("kind") == "real" and s.meta["max_el_deg"] > 20]
    section_pty(real[:args.pty_passes], args.protocol, args.rotator, args.speed)
    if not args.no_upload:
        section_upload(args.protocol)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
