"""benchmarks/streaming.py's parallel flying: the same results in worker processes as in one."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import streaming
from passsuite import overhead_passes

from tracker.mount import preset


def _max_el(sp, offset_deg: float) -> float:
    return float(np.max(sp.track.el_deg)) + offset_deg


def test_pass_map_in_workers_is_the_map_in_one_process_in_order():
    suite = overhead_passes(5)
    args = [(float(i),) for i in range(len(suite))]
    alone = streaming.PassMap(suite, 1)
    shared = streaming.PassMap(suite, 2)
    try:
        assert shared.pool is not None
        assert shared.map(_max_el, args) == alone.map(_max_el, args)
        expected = [_max_el(sp, a) for sp, (a,) in zip(suite, args, strict=True)]
        assert alone.map(_max_el, args) == expected
    finally:
        shared.close()
    assert shared.pool is None


def test_compare_with_two_workers_gives_the_same_results():
    suite = overhead_passes(3)
    spec = preset("G-5500", 50)
    one = streaming.compare(suite, spec, [4.0], peers=False, joint=False)
    two = streaming.compare(suite, spec, [4.0], peers=False, joint=False, workers=2)
    a, b = one["deadbands"][4.0], two["deadbands"][4.0]
    for key in ("max", "p99", "lost_s", "starts", "bound_pp", "in_db"):
        assert a[key] == b[key]
    assert np.array_equal(a["per_pass_starts"], b["per_pass_starts"])
    assert one["lossy"] == two["lossy"]
    assert np.array_equal(one["followable"], two["followable"])


def test_the_bound_on_one_pass_in_n_is_judged_on_those_passes_only():
    suite = overhead_passes(3)
    spec = preset("G-5500", 50)
    res = streaming.compare(suite, spec, [4.0], peers=False, joint=False, bound_every=2)
    r = res["deadbands"][4.0]
    bounds = [streaming.start_bound(suite[i].track, spec, suite[i].station, 4.0)
              for i in (0, 2)]
    assert None not in bounds
    assert r["bound_passes"] == 2
    assert r["bound_pp"] == np.mean(bounds)
    assert r["stream_feasible_pp"] == np.mean(r["per_pass_starts"][[0, 2]])
    # The pass without a bound is neither judged against it nor taken as impossible.
    within, below = r["below_bound"]["stream"]
    assert (within, below) == (int(np.sum(r["per_pass_max"][[0, 2]] <= 4.0 + 1e-9)), 0)
