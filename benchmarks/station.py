"""Station: days of unattended station mode with random faults, on virtual time.

    python benchmarks/station.py                   # 7 simulated days (~18 min CPU)
    python benchmarks/station.py --quick           # 1 day
    python benchmarks/station.py --seed 3 --mode table

The station service (:class:`tracker.service.runner.StationService`) runs the simulation's
schedule (ISS, NOAA 20, METEOR-M2 3, SO-50, AO-7, FUNCUBE-1, IO-117) from 2026-08-22 over
52 N 4.4 E with a horizon mask, on the built-in GS-232B emulator (G-5500) on an in-process
bench, all on one LockstepClock: the run is deterministic for a seed. Random faults from a
seeded RNG:

- the controller unplugged (5 s to an hour), power-cycled, garbled bytes both ways
  (``garble=0.01`` for 1 to 30 min): the emulator's fault plan;
- the network gone during element refreshes: the element keeper downloads from a local HTTP
  server on 127.0.0.1 serving the bundled groups, stopped for 1 to 12 h at a time;
- the service crashing (it stops at once, mid-pass or not) and started again after 5 s to
  20 min: a new service on the same state file, pass log, clock and controller.

Printed: passes scheduled and tracked, and every chosen pass not tracked that overlaps no
controller fault window or restart gap (must be none); commands outside the effective limits
or below the mask, decoded from the bytes the controller received (must be 0); measured vs
predicted max error of the tracked passes; memory (RSS, Python heap) at each simulated day;
state across restarts (no pass tracked twice, no done pass forgotten). Exit 1 if a claim fails.

Memory is RSS, the interpreter's allocated blocks and the objects the garbage collector
tracks, each simulated day; ``--tracemalloc`` adds the traced heap, at about 4x the CPU time.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import random
import shlex
import statistics
import sys
import tempfile
import threading
import time
import traceback
import tracemalloc
import urllib.parse
from collections import Counter
from dataclasses import dataclass, field
from datetime import datetime, timezone
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from _memory import heap_mib, rss_mib

START = datetime(2026, 8, 22, tzinfo=timezone.utc)   # the bundled element epochs
DAY_S = 86400.0
SOURCES = ("stations", "weather", "amateur")          # the groups of the simulation's targets


class ServiceCrash(BaseException):
    """The service process dies: nothing of it runs on (not an Exception: no handler of the
    service catches it)."""


def _clock_class():
    from tracker.clock import LockstepClock

    class CrashingClock(LockstepClock):
        """The run's clock: raises :class:`ServiceCrash` in the first sleep that reaches
        ``crash_s`` (and in every sleep after, until the crash is over), and calls
        ``on_day`` at each simulated day boundary."""

        crash_s = math.inf
        crashed = False
        next_day_s = math.inf
        on_day = staticmethod(lambda: None)

        def sleep(self, seconds: float) -> None:
            if self.crashed:
                raise ServiceCrash
            now_s = self.timestamp()
            if now_s + seconds >= self.crash_s:
                super().sleep(max(0.0, self.crash_s - now_s))
                self.crashed = True
                raise ServiceCrash
            super().sleep(seconds)
            if self.timestamp() >= self.next_day_s:
                self.next_day_s += DAY_S
                self.on_day()

    return CrashingClock


# -- the fault plan -------------------------------------------------------------------------
@dataclass
class Plan:
    emulator: list[str] = field(default_factory=list)     # fault specs, s after the start
    windows: list[tuple[float, float, str]] = field(default_factory=list)  # controller faults
    network: list[tuple[float, float]] = field(default_factory=list)
    restarts: list[tuple[float, float]] = field(default_factory=list)      # crash, back (s)


def fault_plan(rng: random.Random, days: float, per_day: float) -> Plan:
    """Random faults over ``days``; every time in s after the start."""
    plan = Plan()
    end_s = days * DAY_S
    t_s = 1800.0
    while True:
        t_s += rng.expovariate(per_day / DAY_S)
        if t_s >= end_s:
            break
        kind = rng.choice(["disconnect", "disconnect", "powercycle", "powercycle", "garble",
                           "network", "restart"])
        if kind == "disconnect":
            d_s = math.exp(rng.uniform(math.log(5.0), math.log(3600.0)))
            plan.emulator.append(f"disconnect={d_s:.1f}@{t_s:.1f}")
        elif kind == "powercycle":
            d_s = rng.uniform(0.5, 5.0)
            plan.emulator.append(f"powercycle={d_s:.1f}@{t_s:.1f}")
        elif kind == "garble":
            d_s = rng.uniform(60.0, 1800.0)
            plan.emulator.append(f"garble=0.01@{t_s:.1f}+{d_s:.0f}")
        elif kind == "network":
            d_s = rng.uniform(3600.0, 12 * 3600.0)
            plan.network.append((t_s, t_s + d_s))
            continue
        else:
            d_s = rng.uniform(5.0, 1200.0)
            plan.restarts.append((t_s, t_s + d_s))
            t_s += d_s
            continue
        plan.windows.append((t_s, t_s + d_s, kind))
    return plan


# -- the network: a CelesTrak-like GP endpoint on 127.0.0.1 ---------------------------------
class LocalCelestrak:
    """Serves the bundled group files as CelesTrak's GP endpoint; :meth:`set_up` starts or
    stops it (stopped: connection refused). The ETag changes each simulated day, so a daily
    refresh downloads (the same elements) and the station recomputes its schedule."""

    def __init__(self) -> None:
        from importlib.resources import files

        data = files("tle").joinpath("data")
        self.bodies = {g: data.joinpath(f"{g}.txt").read_bytes() for g in SOURCES}
        self.etag = '"d0"'
        self.requests: Counter[str] = Counter()
        self.port = 0
        self.server: ThreadingHTTPServer | None = None
        self.thread: threading.Thread | None = None
        self.set_up(True)
        self.base_url = f"http://127.0.0.1:{self.port}/NORAD/elements/gp.php"

    def _handler(self) -> type[BaseHTTPRequestHandler]:
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:
                pass

            def do_GET(self) -> None:
                query = urllib.parse.parse_qs(urllib.parse.urlsplit(self.path).query)
                group = query.get("GROUP", ["?"])[0].lower()
                body = fake.bodies.get(group)
                if body is None:
                    self.send_error(404)
                    return
                if self.headers.get("If-None-Match") == fake.etag:
                    fake.requests["304"] += 1
                    self.send_response(304)
                    self.send_header("ETag", fake.etag)
                    self.end_headers()
                    return
                fake.requests["200"] += 1
                self.send_response(200)
                self.send_header("Content-Type", "text/plain")
                self.send_header("Content-Length", str(len(body)))
                self.send_header("ETag", fake.etag)
                self.end_headers()
                self.wfile.write(body)

        return Handler

    def set_up(self, up: bool) -> None:
        if up and self.server is None:
            self.server = ThreadingHTTPServer(("127.0.0.1", self.port), self._handler())
            self.server.daemon_threads = True
            self.port = self.server.server_port
            self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
            self.thread.start()
        elif not up and self.server is not None:
            self.server.shutdown()
            self.server.server_close()
            self.server = None

    def close(self) -> None:
        self.set_up(False)


# -- what the controller received ----------------------------------------------------------
class WireCheck:
    """Stands in for the bench's ``written`` list: decodes each line a client wrote (before
    any fault garbles it) and checks every position in it against the effective limits and
    the mask, keeping only counts (a week of bytes would swamp the memory figures)."""

    def __init__(self) -> None:
        self.limits: Any = None
        self.buf = b""
        self.counts: Counter[str] = Counter()
        self.unsafe: list[str] = []

    def append(self, item: tuple[float, bytes]) -> None:
        self.buf += item[1]
        *lines, self.buf = self.buf.split(b"\r")
        for line in lines:
            self.line(line)

    def line(self, raw: bytes) -> None:
        from tracker.protocols import gs232_codec as codec

        msg = codec.decode_command(raw, dialect="gs232", az_max_deg=999, el_max_deg=999)
        if isinstance(msg, codec.Goto):
            self.counts["goto"] += 1
            points = [(msg.az, msg.el)]
        elif isinstance(msg, codec.Table):
            self.counts["table lines"] += 1
            tl = msg.line
            points = list(zip(tl.az, tl.el or [None] * len(tl.az), strict=True))
        else:
            return
        for az, el in points:
            self.counts["positions"] += 1
            if not self.safe(az, el):
                self.unsafe.append(raw.decode("ascii", "replace")[:40])

    def safe(self, az: int, el: int | None) -> bool:
        """Inside the effective limits and, allowing the wire's rounding to whole degrees
        (0.5 deg), not below the mask."""
        from tracker.errors import LimitError

        for e in (el, None if el is None else el + 0.5):
            try:
                self.limits.check_wire(float(az), None if e is None else float(e))
                return True
            except LimitError:
                continue
        return False


# -- the run ---------------------------------------------------------------------------------
@dataclass
class Run:
    outcomes: list[Any] = field(default_factory=list)            # every instance's
    instances: int = 0
    crashes: int = 0
    errors: list[str] = field(default_factory=list)
    forgotten: list[str] = field(default_factory=list)
    carried_skips: set[str] = field(default_factory=set)
    # t, RSS MiB, allocated blocks, objects the gc tracks, traced heap MiB (0: not traced)
    memory: list[tuple[float, float, int, int, float]] = field(default_factory=list)
    said: Counter[str] = field(default_factory=Counter)


def _percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, max(0, math.ceil(q * len(s)) - 1))] if s else math.nan


def _watched_replan(svc: Any, run: Run) -> Any:
    """``svc.replan`` that notes a pass the new schedule chose but carried over as skipped
    (it would never be tracked)."""
    replan = svc.replan

    def watched(*args: Any, **kw: Any) -> None:
        replan(*args, **kw)
        for p in svc.schedule.chosen if svc.schedule else ():
            if p.state == "skipped" and not p.reason.startswith("missed"):
                run.carried_skips.add(f"{p.key} ({p.reason})")
    return watched


def _sample_memory(run: Run, clock: Any) -> None:
    gc.collect()
    run.memory.append((clock.timestamp(), rss_mib(), sys.getallocatedblocks(),
                       len(gc.get_objects()), heap_mib()))


# The benchmark end to end (arguments, rig, the days, report); a script, read top to bottom.
def main(argv: list[str] | None = None) -> int:  # noqa: C901
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--days", type=float, default=7.0, help="simulated days (default 7)")
    ap.add_argument("--quick", action="store_true", help="one simulated day")
    ap.add_argument("--seed", type=int, default=1, help="RNG seed of the fault plan")
    ap.add_argument("--mode", choices=("auto", "stream", "table"), default="auto")
    ap.add_argument("--faults-per-day", type=float, default=12.0)
    ap.add_argument("--tracemalloc", action="store_true",
                    help="trace the Python heap too (about 4x the CPU time)")
    ap.add_argument("--keep", action="store_true", help="keep the state folder (its path is "
                    "printed)")
    args = ap.parse_args(argv)
    days = 1.0 if args.quick else args.days
    print("$ python " + " ".join(shlex.quote(a) for a in [sys.argv[0], *(argv or sys.argv[1:])]),
          flush=True)

    from dataclasses import replace

    from tle.store import TleStore, urllib_fetch
    from tracker.controllers import controller
    from tracker.mount import preset
    from tracker.service.board import StatusBoard
    from tracker.service.elements import ElementKeeper
    from tracker.service.records import STATE_KEEP_S, PassLog, StationState
    from tracker.service.runner import StationService
    from tracker.service.simulate import emulated, simulation_schedule
    from tracker.session import EffectiveLimits
    from tracker.station import HorizonMask, Station
    from tracker.stream import StreamSettings

    if args.tracemalloc:
        tracemalloc.start()
    real0, cpu0 = time.monotonic(), time.process_time()
    rng = random.Random(args.seed)
    plan = fault_plan(rng, days, args.faults_per_day)
    t0_s = START.timestamp()
    end_s = t0_s + days * DAY_S
    station = Station("bench", 52.0, 4.4, mask=HorizonMask((0.0, 120.0, 240.0), (3.0, 8.0, 2.0)))
    spec, entry = preset("G-5500"), controller("gs232b")
    clock = _clock_class()(START)
    bench, connect = emulated(entry, spec, clock, faults=plan.emulator, seed=args.seed)
    wire = WireCheck()
    bench.written = wire                       # type: ignore[assignment]
    driver = connect()
    try:
        wire.limits = EffectiveLimits.of(spec, station, driver.capabilities)
    finally:
        driver.close()

    net = LocalCelestrak()
    net_stats: Counter[str] = Counter()

    def fetch(url: str, headers: Any, timeout_s: float) -> Any:
        rel_s = clock.timestamp() - t0_s
        down = any(a <= rel_s < b for a, b in plan.network)
        net.set_up(not down)
        net.etag = f'"d{int(rel_s // DAY_S)}"'
        net_stats["fetches while down" if down else "fetches"] += 1
        return urllib_fetch(url, headers, timeout_s)

    tmp = Path(tempfile.mkdtemp(prefix="tracker-station-bench-"))
    store = TleStore(cache_dir=tmp / "cache", fetch=fetch, clock=clock, base_url=net.base_url,
                     timeout_s=5.0)
    settings = replace(simulation_schedule(), mode=args.mode, sources=SOURCES)
    state_path, log_path = tmp / "state.json", tmp / "passes.jsonl"
    run = Run()
    say_log = (tmp / "station.log").open("w", encoding="utf-8")

    def say(text: str) -> None:
        say_log.write(text + "\n")
        body = text.split("Z ", 1)[-1]           # after the service's own time stamp
        if body.startswith("fault"):
            run.said["fault lines"] += 1
        elif body.startswith("schedule ("):
            run.said[body.split(")")[0] + ")"] += 1

    clock.next_day_s = t0_s + DAY_S
    clock.on_day = lambda: _sample_memory(run, clock)
    restarts = [(t0_s + a, t0_s + b) for a, b in plan.restarts]
    print(f"station: {days:g} simulated days from {START:%Y-%m-%d} on virtual time, mode "
          f"{args.mode}, seed {args.seed}; {len(plan.emulator)} controller faults, "
          f"{len(plan.network)} network outages, {len(restarts)} restarts planned", flush=True)
    _sample_memory(run, clock)
    done_before: set[str] = set()
    while clock.timestamp() < end_s:
        keeper = ElementKeeper(store, settings.element_sources, clock,
                               refresh_s=settings.refresh_h * 3600.0,
                               events=lambda kind, **d: say(
                                   ("fault: " if kind == "fault" else "") + d["text"]))
        svc = StationService(
            station=station, spec=spec, controller=entry, connect=connect, clock=clock,
            schedule=settings, stream=StreamSettings(), board=StatusBoard(clock, simulated=True),
            keeper=keeper, state_path=state_path, pass_log=PassLog(log_path), say=say)
        svc.replan = _watched_replan(svc, run)     # type: ignore[method-assign]
        run.instances += 1
        nxt = next(((a, b) for a, b in restarts if a > clock.timestamp()), None)
        clock.crash_s = nxt[0] if nxt else math.inf
        try:
            svc.run(until_s=end_s)
        except ServiceCrash:
            run.crashes += 1
        except Exception:   # a traceback is a bug the benchmark must show, not hide
            run.errors.append(traceback.format_exc(limit=6))
            svc.pass_log.close()
            break
        finally:
            clock.crashed, clock.crash_s = False, math.inf
            run.outcomes.extend(svc.report.outcomes)
            svc.pass_log.close()
        done_before |= {o.key for o in svc.report.outcomes if o.outcome == "done"}
        if nxt is not None and clock.timestamp() < end_s:
            clock.advance(max(0.0, nxt[1] - clock.timestamp()))
            # what the next instance starts from: every recent done pass must be there
            state, _warning = StationState.load(state_path)
            recent = {k for k in done_before
                      if any(o.key == k and o.outcome == "done" and
                             datetime.fromisoformat(o.los_utc.replace("Z", "+00:00"))
                             .timestamp() > clock.timestamp() - STATE_KEEP_S
                             for o in run.outcomes)}
            run.forgotten += sorted(k for k in recent
                                    if state.passes.get(k, {}).get("state") != "done")
    net.close()
    say_log.close()
    _sample_memory(run, clock)
    real_s, cpu_s = time.monotonic() - real0, time.process_time() - cpu0

    # -- figures -----------------------------------------------------------------------------
    probe = SimpleNamespace(pass_=SimpleNamespace(aos=START))
    lead_s = t0_s - svc._start_s(probe)        # pre-position + settle before AOS
    windows = [(t0_s + a, t0_s + b, k) for a, b, k in plan.windows]
    windows += [(a, b, "restart") for a, b in restarts]
    windows.append((-math.inf, t0_s, "before the start"))

    def ts(iso: str) -> float:
        return datetime.fromisoformat(iso.replace("Z", "+00:00")).timestamp()

    def overlaps(o: Any) -> list[str]:
        a, b = ts(o.aos_utc) - lead_s, ts(o.los_utc)
        return sorted({k for lo, hi, k in windows if lo <= b and hi >= a})

    by_key: dict[str, list[Any]] = {}
    for o in run.outcomes:
        by_key.setdefault(o.key, []).append(o)
    chosen = {k: v for k, v in by_key.items() if any(o.chosen for o in v)}
    done_counts = Counter(o.key for o in run.outcomes if o.outcome == "done")
    tracked = [v[-1] for k, v in chosen.items() if done_counts[k]]
    not_tracked = [v[-1] for k, v in chosen.items() if not done_counts[k]]
    blamed = [(o, overlaps(o)) for o in not_tracked]
    clean_missed = [o for o, why in blamed if not why]
    twice = sorted(k for k, n in done_counts.items() if n > 1)
    done = [next(o for o in by_key[k] if o.outcome == "done") for k in done_counts]
    clean_done = [o for o in done if not overlaps(o)]
    modes = Counter(o.mode for o in done)
    sim_d = (clock.timestamp() - t0_s) / DAY_S

    def dist(v: list[float]) -> str:
        return (f"median {statistics.median(v):.2f}, p95 {_percentile(v, 0.95):.2f}, "
                f"max {max(v):.2f} deg" if v else "-")

    print("\nstation results")
    print(f"  simulated              {sim_d:.2f} days in {real_s:.0f} s real, {cpu_s:.0f} s CPU "
          f"({cpu_s / max(sim_d, 1e-9) / 60:.1f} min CPU per day)")
    print(f"  service instances      {run.instances} ({run.crashes} crashes and restarts); "
          f"tracebacks {len(run.errors)}")
    print(f"  faults planned         {Counter(k for _a, _b, k in plan.windows)} + "
          f"{len(plan.network)} network outages + {len(restarts)} restarts")
    print(f"  faults injected        {dict(sorted(bench.injector.stats.items()))}"
          if bench.injector else "  faults injected        none")
    print(f"  element fetches        {dict(net_stats)}; server answered {dict(net.requests)}")
    print(f"  service said           {dict(sorted(run.said.items()))}")
    print(f"  passes scheduled       {len(chosen)} chosen; tracked {len(tracked)} "
          f"({dict(modes)}); not tracked {len(not_tracked)}")
    why = Counter(f"{o.outcome}: {o.reason.split(':')[0][:50]}" for o in not_tracked)
    for k, n in sorted(why.items(), key=lambda kv: -kv[1]):
        print(f"    {n:3d} x {k}")
    blame = Counter(k for _o, ks in blamed for k in ks)
    print(f"  not tracked, overlapping a fault: {len(not_tracked) - len(clean_missed)} "
          f"(windows hit: {dict(blame)})")
    print(f"  not tracked, overlapping NO fault: {len(clean_missed)} (must be 0)")
    for o in clean_missed:
        print(f"    {o.key} {o.target} {o.aos_utc}..{o.los_utc} {o.outcome}: {o.reason}")
    if run.carried_skips:
        print(f"  chosen but carried over as skipped: {len(run.carried_skips)} "
              f"{sorted(run.carried_skips)[:5]}")
    print(f"  commands received      {dict(wire.counts)}; outside the limits or below the "
          f"mask: {len(wire.unsafe)} (must be 0) {wire.unsafe[:5]}")
    for label, group in ((f"{len(clean_done)} tracked, no fault", clean_done),
                         (f"all {len(done)} tracked", done)):
        measured = [o.measured_max_error_deg for o in group
                    if o.measured_max_error_deg is not None]
        predicted = [o.predicted_max_error_deg for o in group
                     if o.predicted_max_error_deg is not None]
        excess = [o.measured_max_error_deg - o.predicted_max_error_deg for o in group
                  if o.measured_max_error_deg is not None
                  and o.predicted_max_error_deg is not None]
        print(f"  max error, {label}:")
        print(f"      measured {dist(measured)}")
        print(f"      predicted {dist(predicted)}")
        print(f"      measured - predicted {dist(excess)}; more than 5 deg over: "
              f"{sum(1 for e in excess if e > 5.0)}")
    traced = "traced MiB" if args.tracemalloc else "(no --tracemalloc)"
    print(f"  memory                 day  RSS MiB  py blocks  gc objects  {traced}")
    for t_s, rss, blocks, objs, heap in run.memory:
        print(f"                         {(t_s - t0_s) / DAY_S:4.2f} {rss:8.1f} {blocks:10d} "
              f"{objs:11d}" + (f"  {heap:10.2f}" if args.tracemalloc else ""))
    if len(run.memory) > 2:
        (_t, r1, b1, o1, h1), (_t, r2, b2, o2, h2) = run.memory[1], run.memory[-1]
        print(f"                         day 1 to end: RSS {r2 - r1:+.1f} MiB, blocks "
              f"{b2 - b1:+d}, gc objects {o2 - o1:+d}"
              + (f", traced {h2 - h1:+.2f} MiB" if args.tracemalloc else ""))
    print(f"  state across restarts  passes tracked twice: {len(twice)} {twice[:5]}; done "
          f"passes forgotten by a restart: {len(run.forgotten)} {run.forgotten[:5]}")
    log_lines = sum(1 for _ in log_path.open()) if log_path.exists() else 0
    kept = (len(json.loads(state_path.read_text())["passes"]) if state_path.exists() else 0)
    print(f"  pass log               {log_lines} lines, state file {kept} passes"
          + (f"; folder {tmp}" if args.keep else ""))
    for e in run.errors:
        print("  TRACEBACK\n" + e)
    if not args.keep:
        import shutil

        shutil.rmtree(tmp, ignore_errors=True)
    bad = clean_missed or wire.unsafe or twice or run.forgotten or run.errors
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
