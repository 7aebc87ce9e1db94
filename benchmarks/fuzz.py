"""Fuzz every parser and emulator with many random and near-valid inputs.

    python benchmarks/fuzz.py                       # 100k inputs per target
    python benchmarks/fuzz.py --engine hypothesis   # the same, drawn by hypothesis
    python benchmarks/fuzz.py --count 10000 --only emulator --time-limit-s 60
    python benchmarks/fuzz.py --reply-integrity 20000   # noisy line vs the GS-232 parser

Prints, per target: inputs run, exceptions outside the documented typed errors (grouped by
type, with the first offending input), and inputs per second. Exit status 1 if any target
raised an undocumented exception. The targets are the ones the CI hypothesis tests use
(``tests/_fuzz_targets.py``); the CI runs a few hundred, this runs the full count.
``--engine random`` (default) draws near-valid mutations, random bytes and token soup from
a seeded ``random.Random`` (fastest); ``--engine hypothesis`` draws from the CI tests'
hypothesis strategy (generation only: every input is run, failures are collected, not
shrunk). Hypothesis draws ``--batch`` inputs per example, because its per-example
bookkeeping, not the targets, limits the rate (about 5x faster at 20 than at 1).
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import _fuzz_targets as F


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--count", type=int, default=100_000, help="inputs per target")
    ap.add_argument("--seed", type=int, default=2026, help="RNG seed (reproducible runs)")
    ap.add_argument("--only", default="", help="run targets whose name contains this")
    ap.add_argument("--engine", choices=("random", "hypothesis"), default="random",
                    help="input generator (default random; hypothesis: the CI strategy)")
    ap.add_argument("--batch", type=int, default=20,
                    help="hypothesis engine: inputs drawn per hypothesis example (default 20)")
    ap.add_argument("--time-limit-s", type=float, default=None,
                    help="stop a target after this many seconds (its count is then lower; "
                         "the table says so)")
    ap.add_argument("--reply-integrity", type=int, default=0, metavar="N",
                    help="instead: N C2 replies through 1 %% byte noise, count how many the "
                         "GS-232 parser accepts with a wrong value")
    args = ap.parse_args(argv)
    if args.reply_integrity:
        return reply_integrity(args.reply_integrity, args.seed)

    targets = [t for t in F.targets() if args.only in t.name]
    print(f"fuzz: {len(targets)} targets, {args.count} inputs each, seed {args.seed}, "
          f"engine {args.engine}")
    print(f"{'target':30s} {'inputs':>8s} {'bad':>5s} {'inputs/s':>9s}  notes")
    total_bad = 0
    t_all = time.perf_counter()
    for t in targets:
        n, bad, first, dt = _run_target(t, args)
        notes = "" if n == args.count else f"time limit: {n}/{args.count}"
        tolerated = F.KNOWN_ESCAPES.get(t.name)
        if tolerated:
            notes += (" " if notes else "") + "tolerating known escapes: " + ", ".join(
                e.__name__ for e in tolerated)
        nbad = sum(bad.values())
        total_bad += nbad
        print(f"{t.name:30s} {n:8d} {nbad:5d} {n / dt:9.0f}  {notes}", flush=True)
        for kind, count in bad.items():
            print(f"    {count} x {kind}; first input {first[kind]!r}")
    print(f"total: {total_bad} undocumented exceptions; {time.perf_counter() - t_all:.1f} s")
    return 1 if total_bad else 0


def _run_target(t, args) -> tuple[int, Counter[str], dict[str, bytes], float]:
    """Run one target: inputs run, undocumented exceptions by type, first input of each."""
    bad: Counter[str] = Counter()
    first: dict[str, bytes] = {}
    n = 0
    t0 = time.perf_counter()
    deadline = None if args.time_limit_s is None else t0 + args.time_limit_s

    def one(data: bytes) -> None:
        nonlocal n
        err = F.check(t, data)
        n += 1
        if err is not None:
            bad[type(err).__name__] += 1
            first.setdefault(type(err).__name__, data[:80])
        if deadline is not None and n % 200 == 0 and time.perf_counter() > deadline:
            raise _TimeUp

    try:
        if args.engine == "hypothesis":
            _hypothesis_run(t, args.count, args.seed, args.batch, one)
        else:
            rng = random.Random(f"{args.seed}:{t.name}")
            while n < args.count:
                one(F.random_input(rng, t))
    except _TimeUp:
        pass
    return n, bad, first, time.perf_counter() - t0


class _TimeUp(BaseException):
    """Ends a target at --time-limit-s, and the hypothesis engine's loop once --count inputs
    ran (a BaseException so hypothesis does not catch it)."""


def _hypothesis_run(target, count: int, seed: int, batch: int, one) -> None:
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hseed
    from hypothesis import strategies as st

    left = count
    batch = max(1, batch)

    # Examples that overrun hypothesis' buffer are discarded unrun, so the budget is counted
    # in inputs actually run, with a generous example ceiling.
    @settings(max_examples=4 * (count // batch + 1), deadline=None, database=None,
              phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @hseed(seed)
    @given(data=st.lists(F.hypothesis_inputs(target), min_size=batch, max_size=batch))
    def run(data: list[bytes]) -> None:
        nonlocal left
        for item in data[:left]:
            one(item)
        left -= min(left, len(data))
        if left == 0:
            raise _TimeUp
    try:
        run()
    except _TimeUp:
        if left:
            raise


def reply_integrity(n: int, seed: int) -> int:
    """GS-232 replies carry no checksum: how often does line noise pass as a reading?"""
    from datetime import datetime

    from tracker.clock import ManualClock
    from tracker.emulator import Gs232Controller
    from tracker.emulator.faults import install
    from tracker.errors import ProtocolError
    from tracker.protocols.framing import LineFramer
    from tracker.protocols.gs232 import parse_position

    print(f"reply integrity: {n} C2 replies 'AZ=123  EL=045' per noise kind, seed {seed}")
    print(f"{'noise':22s} {'correct':>8s} {'rejected':>8s} {'wrong':>6s}  examples")
    for spec in ("drop=0.01:out", "duplicate=0.01:out", "garble=0.01:out"):
        ctrl = Gs232Controller("gs232b", clock=ManualClock(datetime.fromisoformat(F.T0)),
                               az_deg=123, el_deg=45)
        install(ctrl, [spec], seed)
        session, framer = ctrl.open_session(), LineFramer(b"\r\n", keep_empty=False)
        counts, examples = Counter(), []
        for _ in range(n):
            for line in framer.feed(session.feed(b"C2\r")):
                try:
                    value = parse_position(line)
                    if value[1] is None:  # the driver refuses a C2 reply without elevation
                        raise ProtocolError("no elevation", line)
                except ProtocolError:
                    counts["rejected"] += 1
                    continue
                ok = value == (123.0, 45.0)
                counts["correct" if ok else "wrong"] += 1
                if not ok and len(examples) < 3:
                    examples.append(f"{line!r}->{value}")
        print(f"{spec:22s} {counts['correct']:8d} {counts['rejected']:8d} {counts['wrong']:6d}"
              f"  {', '.join(examples)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
