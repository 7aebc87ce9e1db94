"""The public Python API of the tracker, in one import.

Everything a program needs to go from element sets to a moving antenna is re-exported here
from the module that owns it (nothing is wrapped: ``tracker.api.plan_pass is
tracker.planner.plan_pass``). ``import tracker`` stays cheap; importing this module loads
numpy and pyserial (skyfield follows on first use). The data flow, the angle frames and which
module owns what are described in ``docs/architecture.md``; the controllers' byte-level
protocols in ``docs/protocols.md``.

Example: the first ISS pass over Delft after 2026-08-22 12:00 UTC, from the bundled elements,
planned for a G-5500 and compiled into a GS-232B step table (one point every 2 s)::

    from tracker.api import (Catalog, MountPath, Station, compile_program, find_passes,
                             plan_pass, preset, resolve_target, utc)

    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    station = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0)
    first = find_passes(iss, station, utc(2026, 8, 22, 12), utc(2026, 8, 23, 12))[0]
    track, spec = first.track(step_s=1.0, pad_s=60.0), preset("G-5500")
    plan = plan_pass(track, spec, station)     # normal, overlap, flip, keyhole ...
    path = MountPath.from_plan(plan, track, spec)
    program = compile_program(path, spec, "gs232b", interval_s=2, station=station)
    print(f"AOS {first.aos:%Y-%m-%d %H:%M} UTC, {plan.mode}: {program.summary()}")

The test suite runs this example (``tests/test_api.py``).
To follow the pass live, open a driver (:func:`open_driver`) on a port URL - a serial device,
``socket://host:port``, or ``emu://gs232b`` for the in-process emulator - and run
:func:`run_pass` inside a :class:`ControllerSession` (or :func:`follow_passes` for several
passes in a row, re-planned from the antenna's real position: ``examples/follow_passes.py``);
to let the controller track by itself, give :attr:`StepProgram.tables` to a
:class:`TableRunner`.
"""

from __future__ import annotations

from tle.cachedir import default_cache_dir
from tle.catalog import Catalog, age_warning, age_warnings
from tle.elements import ElementSet, load_file, parse_text
from tle.errors import (
    AmbiguousSatelliteError,
    TleError,
    TleFetchError,
    TleFormatError,
    TleWarning,
    UnknownSatelliteError,
)
from tle.store import TleStore
from tracker.batch import (
    PartitionedResult,
    PassTable,
    find_passes_batch,
    find_passes_dask,
    iter_passes_batch,
    load_stations,
    plan_summaries,
    satrecs_of,
    select_passes,
    write_passes_dask,
)
from tracker.celestial import (
    RADIO_SOURCES,
    FixedTarget,
    SolarSystemTarget,
    parse_radec,
)
from tracker.clock import (
    Clock,
    LockstepClock,
    ManualClock,
    PacedClock,
    SimClock,
    SystemClock,
    utc,
)
from tracker.config import Config, ScheduleSettings, load_config
from tracker.controllers import CONTROLLERS, Controller, controller, register_controller
from tracker.emulator import EmulatorOptions, Gs232Controller, serve_pty, serve_tcp
from tracker.emulator.faults import parse_fault
from tracker.emulator.virtual import Bench, make_controller
from tracker.errors import (
    ConfigError,
    LimitError,
    OutputExistsError,
    PortLostError,
    PropagationError,
    ProtocolError,
    ReadbackError,
    RotatorIOError,
    RotatorTimeout,
    StallError,
    TargetError,
    TrackerError,
)
from tracker.event_labels import event_labels
from tracker.export import (
    CSV_FIELDS,
    PASS_FIELDS,
    PassRecords,
    pass_records,
    render_chunks,
    to_csv,
    to_ics,
    to_json,
    to_table,
    write_parquet,
)
from tracker.files import write_atomic
from tracker.geometry import MountPath
from tracker.mount import PRESETS, MotorModel, MountFrame, RotatorSpec, preset
from tracker.pass_schedule import Schedule, build_schedule, parse_priorities, schedule_passes
from tracker.passes import Pass, find_passes
from tracker.planner import MountPlan, Move, error_cause, park_position, plan_pass
from tracker.pointing_file import ScheduleError, ScheduleTarget, parse_schedule
from tracker.protocols import Capabilities, RotatorDriver, open_driver
from tracker.schedule import PassSchedule, plan_schedule
from tracker.service.elements import ElementKeeper
from tracker.service.plan import (
    PlannedPass,
    RollingSchedule,
    build_rolling_schedule,
    wanted_targets,
)
from tracker.service.rotctld_server import RotctldServer
from tracker.session import ControllerSession, EffectiveLimits, Interrupted, driver_limits
from tracker.skytrack import SkyTrack
from tracker.station import HorizonMask, Station, locator_lat_lon, parse_station
from tracker.steptable import (
    StepProgram,
    StepTable,
    TableProfile,
    compile_pass,
    compile_program,
    read_plan_file,
    table_profile,
    tables_from_points,
    write_plan_file,
)
from tracker.stream import Link, PassResult, Status, StreamSettings, TrackCore, run_pass
from tracker.targets import SatelliteTarget, Target, resolve_target
from tracker.tracking import (
    DemoTime,
    PassFollower,
    SharedAzAz,
    demo_speed,
    demo_start,
    describe_pass,
    describe_result,
    follow_passes,
    follow_together,
    next_pass,
)
from tracker.transport import open_port
from tracker.upload import TableRunner, UploadReport

__all__ = [  # noqa: RUF022 (grouped by topic, the order the docs follow)
    # element sets and the catalogue
    "Catalog", "ElementSet", "TleStore", "age_warning", "age_warnings", "default_cache_dir",
    "load_file", "parse_text",
    # time
    "Clock", "LockstepClock", "ManualClock", "PacedClock", "SimClock", "SystemClock", "utc",
    # targets
    "RADIO_SOURCES", "FixedTarget", "SatelliteTarget", "ScheduleTarget", "SkyTrack",
    "SolarSystemTarget", "Target", "event_labels", "parse_radec", "parse_schedule",
    "resolve_target",
    # station and configuration
    "Config", "HorizonMask", "Station", "load_config", "locator_lat_lon", "parse_station",
    # passes
    "Pass", "find_passes",
    # rotators
    "PRESETS", "MotorModel", "MountFrame", "RotatorSpec", "preset",
    # planning; the whole-pass command schedule with the fewest motor starts
    "MountPlan", "Move", "error_cause", "park_position", "plan_pass", "PassSchedule",
    "plan_schedule",
    # step tables
    "MountPath", "StepProgram", "StepTable", "TableProfile", "TableRunner", "UploadReport",
    "compile_pass", "compile_program", "read_plan_file", "table_profile",
    "tables_from_points", "write_plan_file",
    # drivers and ports
    "CONTROLLERS", "Capabilities", "Controller", "RotatorDriver", "controller", "open_driver",
    "open_port", "register_controller",
    # the live session
    "ControllerSession", "EffectiveLimits", "Interrupted", "Link", "PassResult", "Status",
    "StreamSettings", "TrackCore", "driver_limits", "run_pass",
    # following passes: one antenna pass after pass, the demo's time, two antennas on AZ/AZ
    "DemoTime", "PassFollower", "SharedAzAz", "demo_speed", "demo_start", "describe_pass",
    "describe_result", "follow_passes", "follow_together", "next_pass",
    # station mode: the rotctld-compatible control port
    "RotctldServer",
    # emulated controllers
    "Bench", "EmulatorOptions", "Gs232Controller", "make_controller", "parse_fault",
    "serve_pty", "serve_tcp",
    # batch, scheduling, export
    "CSV_FIELDS", "PASS_FIELDS", "PassRecords", "PassTable", "Schedule", "build_schedule",
    "find_passes_batch", "find_passes_dask", "iter_passes_batch", "load_stations",
    "parse_priorities", "pass_records", "plan_summaries", "satrecs_of", "schedule_passes",
    "select_passes",
    "render_chunks", "to_csv", "to_ics", "to_json", "to_table", "write_atomic",
    "write_parquet", "write_passes_dask", "PartitionedResult",
    # station mode: the [schedule] settings, the rolling schedule, fresh elements
    "ScheduleSettings", "PlannedPass", "RollingSchedule", "build_rolling_schedule",
    "wanted_targets", "ElementKeeper",
    # errors (TrackerError and TleError are the two roots)
    "TrackerError", "ConfigError", "TargetError", "PropagationError", "LimitError",
    "RotatorIOError", "PortLostError", "RotatorTimeout", "ProtocolError", "StallError",
    "ReadbackError", "ScheduleError", "OutputExistsError",
    "TleError", "TleFormatError", "UnknownSatelliteError", "AmbiguousSatelliteError",
    "TleFetchError", "TleWarning",
]
