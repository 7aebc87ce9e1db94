"""Parse speed of the validating TLE parser against a bare sgp4 baseline (same run).

Usage: python benchmarks/bench_tle_parse.py [FILE]  (default: a copy of CelesTrak's active
catalogue beside the checkout if there is one, else the bundled snapshot). Prints the median
of 5 runs of: tle.elements.parse_tle_text (layout, checksums, Alpha-5, id match, epoch) and
the baseline sgp4 Satrec.twoline2rv on the same line pairs (no validation), plus the ratio.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

from sgp4.api import Satrec

from tle.elements import parse_tle_text

ROOT = Path(__file__).resolve().parent.parent


def median_s(func, runs: int = 5) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    default = ROOT.parent / "shared" / "tle" / "active.txt"
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else (
        default if default.exists() else ROOT / "tle" / "data" / "visual.txt")
    text = path.read_text()
    sets = parse_tle_text(text, source=str(path))
    pairs = [(es.line1, es.line2) for es in sets]
    ours = median_s(lambda: parse_tle_text(text, source=str(path)))
    base = median_s(lambda: [Satrec.twoline2rv(a, b) for a, b in pairs])
    print(f"file: {path} ({len(sets)} sets)")
    print(f"parse_tle_text (validating): {ours * 1e3:8.1f} ms  "
          f"({ours / len(sets) * 1e6:.1f} us/set)")
    print(f"sgp4 twoline2rv (baseline):  {base * 1e3:8.1f} ms  "
          f"({base / len(sets) * 1e6:.1f} us/set)")
    print(f"ratio ours/baseline: {ours / base:.2f}")


if __name__ == "__main__":
    main()
