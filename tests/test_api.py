"""``tracker.api``, the one public import: its ``__all__`` resolves, the examples use nothing
else, ``import tracker`` stays cheap, its docstring example runs, and a whole job (elements ->
target -> pass -> mount plan -> step table -> the live loop on the in-process emulator) works
through it alone."""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from datetime import datetime, timezone
from pathlib import Path

import pytest

import tracker.api as api

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_every_name_in_all_resolves():
    missing = [name for name in api.__all__ if not hasattr(api, name)]
    assert not missing


def test_all_has_no_duplicates():
    seen: set[str] = set()
    dups = [name for name in api.__all__ if name in seen or seen.add(name)]
    assert not dups


def test_names_are_re_exports_not_wrappers():
    # each public name is the owning module's own object (no copies, no shims)
    from tracker import planner, protocols, session, steptable

    assert api.plan_pass is planner.plan_pass
    assert api.open_driver is protocols.open_driver
    assert api.ControllerSession is session.ControllerSession
    assert api.compile_program is steptable.compile_program
    assert all(getattr(api, n).__module__ != "tracker.api" for n in api.__all__
               if hasattr(getattr(api, n), "__module__"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_examples_import_only_from_tracker_api(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    project = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            mods = [node.module]
        elif isinstance(node, ast.Import):
            mods = [a.name for a in node.names]
        else:
            continue
        project += [m for m in mods if m.split(".")[0] in ("tracker", "tle")]
    assert project, f"{path.name} imports nothing from the project"
    assert set(project) == {"tracker.api"}, project


def test_import_tracker_loads_no_heavy_dependency():
    code = ("import sys, tracker; "
            "print(' '.join(m for m in ('skyfield', 'numpy', 'serial') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip()
    assert out == "", f"import tracker loaded: {out}"


def test_import_tracker_does_not_import_the_api():
    code = "import sys, tracker; print('tracker.api' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip()
    assert out == "False"


def test_docstring_example_runs(capsys):
    # the indented block after "::", up to the first line that is not indented
    lines = []
    for line in api.__doc__.split("::\n", 1)[1].splitlines():
        if line.strip() and not line.startswith("    "):
            break
        lines.append(line)
    code = textwrap.dedent("\n".join(lines)).strip()
    assert 5 <= len(code.splitlines()) <= 12
    exec(compile(code, "tracker.api docstring", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("AOS 2026-08-23 ") and "W table on gs232b" in out


def test_end_to_end_through_the_api_only():
    from tracker.api import (
        Bench,
        Catalog,
        ControllerSession,
        Link,
        ManualClock,
        MountPath,
        Station,
        StreamSettings,
        TrackCore,
        compile_program,
        driver_limits,
        find_passes,
        make_controller,
        open_driver,
        plan_pass,
        preset,
        resolve_target,
        run_pass,
        utc,
    )

    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    moon = resolve_target("moon")
    assert iss.kind == "satellite" and moon.kind == "moon"
    station = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0)
    passes = find_passes(iss, station, utc(2026, 8, 22, 12), utc(2026, 8, 23, 12))
    assert passes and all(p.max_el_deg >= 5.0 for p in passes)
    first = passes[0]
    spec = preset("G-5500")
    track = first.track(step_s=1.0, pad_s=60.0)
    plan = plan_pass(track, spec, station, current=(0.0, 0.0))
    program = compile_program(MountPath.from_plan(plan, track, spec), spec, "gs232b",
                              interval_s=2, station=station)
    assert program.tables and program.lines()[0].startswith("W002 ")

    # The live loop on the in-process emulator, all on one virtual clock: every wait is a
    # jump of the clock, so the whole pass costs CPU time only.
    start_s = min(plan.preposition_t_s, first.aos.timestamp()) - 30.0
    clock = ManualClock(datetime.fromtimestamp(start_s, timezone.utc))
    settings = StreamSettings(park_after_pass=False)
    with Bench(make_controller("gs232b", clock, rotator="G-5500", az_deg=0.0,
                               el_deg=0.0)) as bench:
        link = Link(lambda: open_driver(bench.url, "gs232b", clock=clock,
                                        **driver_limits(spec)), spec)
        try:
            with ControllerSession(link.stop, stop_at_end=True):
                result = run_pass(TrackCore(plan, track, spec, station, settings), link,
                                  clock)
        finally:
            link.drop()
        wire = bench.bytes_written()
    assert result.completed and result.commands >= 5
    assert clock.timestamp() >= first.los.timestamp()
    # within the plan's own prediction plus the deadband (and one motor step)
    assert result.max_error_deg <= plan.max_error_deg + settings.deadband_deg + 1.0
    assert wire.endswith(b"S\r")            # all-stop is the last thing on the wire
