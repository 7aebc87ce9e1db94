"""Decision cost of the live loop per cycle, and its command transcript on a pass sample.

Run: ``python benchmarks/decision_cost.py [--passes 40] [--days 1] [--max-sats 30]
[--save FILE | --check FILE] [--kernels best|numba|numpy]``

Flies an evenly spread sample of the pass suite (benchmarks/passsuite.py) with the stream
policy of benchmarks/streaming.py (G-5500 at 50 Hz, deadband 3 deg, 0.5 s cycle) and prints

* the decision cost per cycle: CPU time of what the live loop asks of
  :class:`tracker.stream.TrackCore` each cycle (observe, decide, commanded, status) divided by
  the cycles flown, the whole-pass schedule's planning (once a pass, within one decision
  before the pre-position) apart;
* that planning's CPU per pass;
* the simulation CPU per pass (planning, the simulated rotator and the decisions).

``--save`` writes the command transcript (time, mechanical az, el of every command of every
pass); ``--check`` flies the same sample and compares against a saved transcript: the same
commands at the same instants, az / el equal to 1e-9. Used to show a faster decision core
decides the same.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import pass_suite, sample_suite
from streaming import CycleMeter, fly_stream

from tracker import compiled
from tracker.mount import preset

TOL_DEG = 1e-9


def pass_key(sp) -> str:
    return f"{sp.meta['target']}|{sp.meta['station']}|{float(sp.track.t_s[0]):.0f}"


def diff_transcripts(saved: dict, now: dict) -> list[str]:
    """Differences between two transcripts (pass key -> [[t, az, el], ...])."""
    out = []
    for key, cmds in now.items():
        ref = saved.get(key)
        if ref is None:
            out.append(f"{key}: not in the saved transcript")
            continue
        if len(ref) != len(cmds):
            out.append(f"{key}: {len(cmds)} commands, saved {len(ref)}")
            continue
        for (t, az, el), (t0, az0, el0) in zip(cmds, ref, strict=True):
            el_same = (el is None and el0 is None) or (
                el is not None and el0 is not None and abs(el - el0) <= TOL_DEG)
            if t != t0 or abs(az - az0) > TOL_DEG or not el_same:
                out.append(f"{key}: at t={t} ({az}, {el}), saved t={t0} ({az0}, {el0})")
                break
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=float, default=1.0)
    ap.add_argument("--max-sats", type=int, default=30, help="satellites per group (0 = all)")
    ap.add_argument("--passes", type=int, default=40, help="sample size (0 = whole suite)")
    ap.add_argument("--deadband", type=float, default=3.0)
    ap.add_argument("--save", type=Path, help="write the command transcript here")
    ap.add_argument("--check", type=Path, help="compare with a transcript saved before")
    ap.add_argument("--kernels", choices=("best", "numba", "numpy"), default="best",
                    help="the whole-pass programme's implementation (best: numba when it runs "
                         "here)")
    args = ap.parse_args(argv)
    compiled.use(compiled.best() if args.kernels == "best" else args.kernels)
    spec = preset("G-5500", 50)
    suite = pass_suite(days=args.days, max_sats=args.max_sats or None)
    sample = sample_suite(suite, args.passes)
    meter = CycleMeter()
    transcript: dict[str, list] = {}
    c0 = time.process_time()
    for sp in sample:
        cmds, _plan, _t = fly_stream(sp.track, spec, sp.station, args.deadband, meter=meter)
        transcript[pass_key(sp)] = [[t, az, el] for t, az, el in cmds]
    cpu_s = time.process_time() - c0
    print(f"{len(sample)} of {len(suite)} passes ({args.days:g} d, {args.max_sats or 'all'} "
          f"sats/group), {spec.name}, deadband {args.deadband:g} deg: {meter.cycles} cycles; "
          f"kernels: {compiled.backend()}")
    print(f"decision cost per cycle (observe+decide+commanded+status, CPU): "
          f"{meter.us_per_cycle:.1f} us")
    print(f"whole-pass schedule, planned once a pass (not counted above): "
          f"{meter.plan_ns / 1e6 / max(meter.plans, 1):.0f} ms CPU per plan, {meter.plans} plans")
    print(f"simulation CPU per pass: {1000 * cpu_s / len(sample):.0f} ms")
    if args.save:
        args.save.write_text(json.dumps(transcript))
        print(f"transcript of {sum(map(len, transcript.values()))} commands saved to "
              f"{args.save}")
    if args.check:
        diffs = diff_transcripts(json.loads(args.check.read_text()), transcript)
        same = len(transcript) - len(diffs)
        print(f"transcript check against {args.check}: {same} of {len(transcript)} passes "
              f"identical (commands at the same instants, az/el within {TOL_DEG:g} deg)")
        for d in diffs[:20]:
            print("  " + d)
        return 1 if diffs else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
