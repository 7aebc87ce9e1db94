"""Benchmark: ``tracker batch`` end to end against the batch finder alone. Asserts nothing.

Runs, one after the other in the same run (so both see the same machine load), two child
processes and measures each from outside (``os.wait4``: CPU = user + system of the process,
wall, and peak RSS):

1. the CLI: ``tracker batch TLE --days 7 --format FMT --out TMP --at ... --lat 52 --lon 4.37``;
2. the API: a fresh Python that imports the library, loads the same file, and calls
   ``find_passes_batch`` on the same station and window (no export).

It prints both, the CLI/API ratios (goal: CPU <= 1.3x) and the CLI's peak RSS (goal
<= 512 MB). Data: CelesTrak's active catalogue of 2026-03-19 (14,710 objects; not in the
repository, give it with ``--tle PATH``).

Usage: python benchmarks/batch_cli.py [--tle PATH] [--format csv|json|parquet] [--days N]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

AT = "2026-03-19T04:51Z"
LAT, LON = 52.0, 4.37
DEFAULT_TLE = Path(__file__).resolve().parents[1].parent / "shared" / "tle" / "active.txt"

FINDER = """
import sys
from datetime import datetime, timedelta, timezone
from tle.elements import load_file
from tracker.batch import find_passes_batch, satrecs_of
from tracker.station import Station
path, days, lat, lon = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
start = datetime(2026, 3, 19, 4, 51, tzinfo=timezone.utc)
sets = load_file(path, skip_bad=True, on_warning=lambda m: None)
satrecs, names = satrecs_of(sets)
table = find_passes_batch(satrecs, names, [Station("bench", lat, lon)], start,
                          start + timedelta(days=days))
print(len(table), file=sys.stderr)
"""


def run_child(argv: list[str], env: dict) -> dict:
    """Run ``argv``; its wall time, CPU time (user + system) and peak RSS in MB."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        sys.exit(f"{argv[:4]} failed ({proc.returncode}):\n{err}")
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
            "rss_mb": usage.ru_maxrss / 1024.0, "stderr": err.strip().splitlines()[-1:]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tle", type=Path, default=DEFAULT_TLE)
    ap.add_argument("--format", default="csv", choices=("csv", "json", "parquet", "ics"))
    ap.add_argument("--days", type=float, default=7.0)
    args = ap.parse_args()
    if not args.tle.exists():
        sys.exit(f"{args.tle}: no such file; give the catalogue with --tle PATH")
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    with tempfile.TemporaryDirectory() as tmp:
        env["HOME"] = tmp  # no user config: the station comes from --lat/--lon alone
        out = Path(tmp) / f"passes.{args.format}"
        cli = [sys.executable, "-m", "tracker.cli", "batch", str(args.tle), "--days",
               str(args.days), "--format", args.format, "--out", str(out), "--at", AT,
               "--lat", str(LAT), "--lon", str(LON)]
        finder = [sys.executable, "-c", FINDER, str(args.tle), str(args.days), str(LAT),
                  str(LON)]
        api = run_child(finder, env)
        cli_r = run_child(cli, env)
        size_mb = out.stat().st_size / 1e6
    print(f"catalogue {args.tle} x {args.days:g} days, station {LAT} N {LON} E")
    print(f"command: {' '.join(cli[2:])}")
    for label, r in (("API (load + find_passes_batch)", api), (f"CLI --format {args.format}",
                                                                 cli_r)):
        print(f"  {label:<32} CPU {r['cpu_s']:7.2f} s  wall {r['wall_s']:7.2f} s  "
              f"peak RSS {r['rss_mb']:7.1f} MB   {' '.join(r['stderr'])}")
    print(f"  output {size_mb:.1f} MB")
    print(f"  CLI / API: CPU {cli_r['cpu_s'] / api['cpu_s']:.2f}x (goal <= 1.3x), wall "
          f"{cli_r['wall_s'] / api['wall_s']:.2f}x; CLI peak RSS {cli_r['rss_mb']:.0f} MB "
          f"(goal <= 512 MB)")


if __name__ == "__main__":
    main()
