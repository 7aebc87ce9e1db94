"""Single-target cost as a whole process: ``tracker passes ISS`` against the bare import of
what it cannot do without, and what ``tracker --help`` loads.

    python benchmarks/single_target.py [--runs 15]

1. ``tracker passes ISS --at 2026-08-23T00:00Z --lat 52 --lon 4.4`` (A) and
   ``python -c "import skyfield.api, numpy, serial"`` (B) run in turn, A B A B ..., each a
   fresh interpreter; per pair the ratio A/B of CPU time (user + system of the child, from
   ``getrusage``) and of wall time. Printed: the medians of A, B and of the pair ratios
   (goal: A/B <= 1.3). A warm-up run of each writes the byte-code caches first (also when
   PYTHONDONTWRITEBYTECODE is set), so neither side pays for compiling.
2. The modules ``tracker --help`` and ``tracker passes ISS`` import (``-X importtime``): the
   third-party packages, and any network module (ssl, http.client, urllib.request). Goals:
   ``--help`` loads neither numpy nor skyfield; nothing network-related loads offline.
3. The pass search itself, warm and in-process: ``find_passes`` of the ISS over one day
   (the median and the least CPU time of 40 calls in one child process, after a first
   call; the least is the one a busy machine disturbs least).

The element cache and config are empty temp dirs, so the bundled snapshot is used.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PASSES = ["-m", "tracker", "passes", "ISS", "--at", "2026-08-23T00:00Z",
          "--lat", "52", "--lon", "4.4"]
BARE = ["-c", "import skyfield.api, numpy, serial"]
NETWORK = ("ssl", "http.client", "urllib.request")
FIND = """
import statistics, time
from datetime import datetime, timedelta, timezone
from tle.catalog import Catalog
from tracker.passes import find_passes
from tracker.station import Station
from tracker.targets import resolve_target
iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
here, t0 = Station("x", 52.0, 4.4), datetime(2026, 8, 23, tzinfo=timezone.utc)
find_passes(iss, here, t0, t0 + timedelta(days=1))
cpu = []
for _ in range(40):
    c = time.process_time()
    find_passes(iss, here, t0, t0 + timedelta(days=1))
    cpu.append(time.process_time() - c)
print(f"median {statistics.median(cpu) * 1000:.1f} ms, min {min(cpu) * 1000:.1f} ms")
"""


def run(argv: list[str], env: dict) -> tuple[float, float]:
    """(cpu_s, wall_s) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *argv], capture_output=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"{argv} failed: {proc.stderr.decode(errors='replace')}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


def imported(argv: list[str], env: dict) -> list[str]:
    proc = subprocess.run([sys.executable, "-X", "importtime", *argv], capture_output=True,
                          text=True, env=env)
    return [line.rsplit("|", 1)[1].strip() for line in proc.stderr.splitlines()
            if line.startswith("import time:") and "|" in line][1:]


def third_party(modules: list[str]) -> list[str]:
    """Top-level packages that are not the standard library (or this project)."""
    stdlib = set(sys.stdlib_module_names)
    tops = {m.split(".")[0] for m in modules}
    return sorted(t for t in tops if t not in stdlib and not t.startswith("_")
                  and t not in ("tracker", "tle"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15, help="pairs of runs (default 15)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "tracker.toml"
        config.write_text("")
        env = dict(os.environ, XDG_CACHE_HOME=f"{tmp}/cache", TRACKER_CONFIG=str(config),
                   PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT),
                                                            os.environ.get("PYTHONPATH")])))
        warm = {k: v for k, v in env.items() if k != "PYTHONDONTWRITEBYTECODE"}
        run(PASSES, warm), run(BARE, warm), run(["-m", "tracker", "--help"], warm)

        a_cpu, a_wall, b_cpu, b_wall, r_cpu, r_wall = [], [], [], [], [], []
        for _ in range(args.runs):
            ac, aw = run(PASSES, env)
            bc, bw = run(BARE, env)
            a_cpu.append(ac), a_wall.append(aw), b_cpu.append(bc), b_wall.append(bw)
            r_cpu.append(ac / bc), r_wall.append(aw / bw)
        med = statistics.median
        print(f"1. whole process, median of {args.runs} pairs (A B A B ...)")
        print(f"   A `tracker passes ISS --at ...`             cpu {med(a_cpu):.3f} s  "
              f"wall {med(a_wall):.3f} s")
        print(f"   B `python -c 'import skyfield.api, numpy, serial'`  cpu {med(b_cpu):.3f} s  "
              f"wall {med(b_wall):.3f} s")
        print(f"   A/B: cpu {med(r_cpu):.2f} [{min(r_cpu):.2f}..{max(r_cpu):.2f}]  "
              f"wall {med(r_wall):.2f} [{min(r_wall):.2f}..{max(r_wall):.2f}]  (goal <= 1.3)")

        print("\n2. imports")
        for label, argv in (("tracker --help", ["-m", "tracker", "--help"]),
                            ("tracker passes ISS", PASSES)):
            mods = imported(argv, env)
            net = [m for m in NETWORK if m in mods]
            print(f"   {label}: {len(mods)} modules; third-party: "
                  f"{', '.join(third_party(mods)) or 'none'}; network: "
                  f"{', '.join(net) or 'none'}")

        ms = subprocess.run([sys.executable, "-c", FIND], env=env, capture_output=True,
                            text=True, check=True).stdout.strip()
        print(f"\n3. find_passes ISS, 1 day, warm, in-process, CPU of 40 calls: {ms}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
