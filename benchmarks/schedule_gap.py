"""Where the motor starts above the clairvoyant bound come from, per deadband.

Run: ``python benchmarks/schedule_gap.py [--passes 60] [--deadband 2 3 4 5] [--days 1]
[--kernels best|numba|numpy]``

Flies an evenly spread sample of the pass suite (benchmarks/passsuite.py) as
benchmarks/streaming.py does (G-5500 at 50 Hz, 0.5 s cycle, the whole-pass schedule planned
before the pre-position) and, on the passes where that one schedule carries the whole pass,
prints three totals of motor starts, each against the clairvoyant lower bound from park
(:func:`tracker.startbound.start_lower_bound`) of the same passes:

* the programme's first answer (:meth:`tracker.fewest_starts.StartsProgramme.solve` at the
  loop's band, the pre-position moves included): the best schedule of its class, with the
  band kept at the half-cycle samples;
* the schedule the loop takes (:func:`tracker.schedule.plan_schedule`): checked between the
  samples too and, where the band is not kept there, planned again within a narrowed band;
* the starts as flown, from park (the pre-position's mask-safe moves counted one by one).

The first is what this class of schedule can reach; the steps between them are what the
check between samples and the pre-position cost. Observes the loop's own planning calls
(both functions wrapped for the run); prints figures, asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import time
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from passsuite import pass_suite, sample_suite
from streaming import fly_stream, measure, start_bound

import tracker.fewest_starts as fewest_starts
import tracker.stream as stream
from tracker import compiled
from tracker.mount import preset


@contextmanager
def observed(log: list):
    """Each call of the loop's ``plan_schedule`` appended to ``log`` as (the starts of every
    programme answer it took, in order; the schedule's or None)."""
    plan, solve = stream.plan_schedule, fewest_starts.StartsProgramme.solve
    answers: list = []

    def solve_seen(self, band_deg, from_s=None):
        found = solve(self, band_deg, from_s)
        answers.append(None if found is None else found.starts)
        return found

    def plan_seen(*args, **kwargs):
        answers.clear()
        sch = plan(*args, **kwargs)
        log.append((list(answers), sch))
        return sch

    stream.plan_schedule, fewest_starts.StartsProgramme.solve = plan_seen, solve_seen
    try:
        yield
    finally:
        stream.plan_schedule, fewest_starts.StartsProgramme.solve = plan, solve


def gap(suite, spec, deadband_deg: float) -> dict:
    out = dict(passes=0, other=0, first=0, narrowed_passes=0, schedule=0, flown=0, bound=0)
    for sp in suite:
        log: list = []
        with observed(log):
            cmds, plan, _t = fly_stream(sp.track, spec, sp.station, deadband_deg)
        answers, sch = log[0] if len(log) == 1 else ([], None)
        bound = start_bound(sp.track, spec, sp.station, deadband_deg)
        if sch is None or not answers or answers[0] is None or not bound:
            out["other"] += 1    # no schedule, planned more than once, or no bound
            continue
        t_start = min(plan.preposition_t_s, float(sp.track.t_s[0])) - 0.5
        flown = measure(sp.track, spec, sp.station, cmds, t_start)["starts"]
        out["passes"] += 1
        out["first"] += answers[0]
        out["narrowed_passes"] += len(answers) > 1
        out["schedule"] += answers[-1]   # the answer taken (its pre-position moves too)
        out["flown"] += flown
        out["bound"] += bound
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--passes", type=int, default=60, help="sample size")
    ap.add_argument("--days", type=float, default=1.0)
    ap.add_argument("--deadband", type=float, nargs="+", default=[2.0, 3.0, 4.0, 5.0])
    ap.add_argument("--kernels", choices=("best", "numba", "numpy"), default="best")
    args = ap.parse_args(argv)
    compiled.use(compiled.best() if args.kernels == "best" else args.kernels)
    spec = preset("G-5500", 50)
    suite = sample_suite(pass_suite(days=args.days), args.passes)
    print(f"{len(suite)} passes, kernels {compiled.backend()}; starts summed over the passes "
          f"one schedule carries from the pre-position to LOS, each x the bound")
    for d in args.deadband:
        c = time.process_time()
        g = gap(suite, spec, d)
        b = max(g["bound"], 1)
        print(f"  {d:g} deg: {g['passes']} passes ({g['other']} others), bound {g['bound']}; "
              f"first answer {g['first'] / b:.3f}x, the schedule taken {g['schedule'] / b:.3f}x "
              f"(planned again on {g['narrowed_passes']}), flown {g['flown'] / b:.3f}x "
              f"[{time.process_time() - c:.0f} s CPU]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
