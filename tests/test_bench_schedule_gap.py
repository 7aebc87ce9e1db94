"""benchmarks/schedule_gap.py: the starts it sums are consistent with each other and the bound,
and it leaves the loop's planning functions as it found them."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import schedule_gap
from passsuite import overhead_passes

import tracker.fewest_starts as fewest_starts
import tracker.stream as stream
from tracker.mount import preset


def test_the_first_answer_is_between_the_bound_and_the_schedule_taken():
    plan, solve = stream.plan_schedule, fewest_starts.StartsProgramme.solve
    g = schedule_gap.gap(overhead_passes(2), preset("G-5500", 50), 3.0)
    assert g["passes"] + g["other"] == 2 and g["passes"] >= 1
    # A narrower band never needs fewer starts; no schedule makes fewer than the bound.
    assert g["bound"] <= g["first"] <= g["schedule"]
    assert g["flown"] >= g["bound"]
    assert stream.plan_schedule is plan
    assert fewest_starts.StartsProgramme.solve is solve
