"""The station service on virtual time: the built-in GS-232B emulator (G-5500) on an
in-process bench, the bundled element snapshot, a stretch of 2026-08-22 over 52 N 4.4 E.

Every scenario asserts what the controller received (table lines, T, goto, stop) or what the
service wrote, not only the absence of an error: passes tracked in both modes, a restart that
picks up where it was, the controller unplugged and jammed, the clock jumping, a SIGHUP
reload, a state file that cannot be written.
"""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import pytest

from tle.catalog import Catalog
from tracker.clock import LockstepClock
from tracker.config import ScheduleSettings
from tracker.controllers import controller
from tracker.errors import ConfigError
from tracker.mount import preset
from tracker.service.board import StatusBoard
from tracker.service.records import PassLog, StationState
from tracker.service.runner import StationService
from tracker.service.simulate import emulated
from tracker.station import Station
from tracker.stream import StreamSettings

STATION = Station(name="home", lat_deg=52.0, lon_deg=4.4)
SPEC = preset("G-5500")
GS232B = controller("gs232b")
# NOAA 20 (JPSS-1) rises 13:04:48 and sets 13:19:58 UTC (max el 42 deg) over the station.
BEFORE_NOAA20 = datetime(2026, 8, 22, 12, 55, tzinfo=timezone.utc)
NOAA20_LOS_S = datetime(2026, 8, 22, 13, 19, 58, tzinfo=timezone.utc).timestamp()


@pytest.fixture(scope="module")
def catalog():
    return Catalog.bundled_snapshot()


class Station_:
    """One service on a fresh emulator, and what it said."""

    def __init__(self, catalog, *, mode: str = "table", start: datetime = BEFORE_NOAA20,
                 targets: dict | None = None, faults=(), state_path: Path | None = None,
                 log_path: Path | None = None, clock=None):
        self.clock = clock or LockstepClock(start)
        self.bench, connect = emulated(GS232B, SPEC, self.clock, faults=faults)
        self.lines: list[str] = []
        self.board = StatusBoard(self.clock, simulated=True)
        self.settings = ScheduleSettings(targets=targets or {"NOAA 20": 1}, mode=mode,
                                         horizon_h=6.0)
        self.service = StationService(
            station=STATION, spec=SPEC, controller=GS232B, connect=connect, clock=self.clock,
            schedule=self.settings, stream=StreamSettings(), board=self.board,
            catalog=catalog, state_path=state_path,
            pass_log=PassLog(log_path) if log_path else None, say=self.say)
        self.hooks: list = []

    def say(self, text: str) -> None:
        self.lines.append(text)
        for hook in list(self.hooks):
            hook(text)

    def run_until(self, t: datetime):
        try:
            return self.service.run(until_s=t.timestamp())
        finally:
            self.wire = self.bench.bytes_written()
            self.bench.close()

    def said(self, part: str) -> list[str]:
        return [line for line in self.lines if part in line]


def _done(report) -> list:
    return [o for o in report.outcomes if o.outcome == "done"]


def test_a_pass_runs_as_a_step_table_and_is_logged(catalog, tmp_path):
    st = Station_(catalog, mode="table", state_path=tmp_path / "state.json",
                  log_path=tmp_path / "passes.jsonl")
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    done = _done(report)
    assert [o.target for o in done] == ["NOAA 20 (JPSS-1)"]
    o = done[0]
    assert o.mode == "table" and o.measured_max_error_deg is not None
    assert o.measured_max_error_deg <= o.predicted_max_error_deg + 1.0
    wire = st.wire
    assert b"\rT\r" in b"\r" + wire or b"T\r" in wire       # the table was started
    tables = [line for line in wire.split(b"\r") if line.startswith(b"W")]
    assert max(len(line.split()) for line in tables) > 200  # uploaded as a long W line
    log = [json.loads(x) for x in (tmp_path / "passes.jsonl").read_text().splitlines()]
    assert [r["outcome"] for r in log if r["chosen"]] == ["done"]
    state, warning = StationState.load(tmp_path / "state.json")
    assert warning == "" and state.passes[o.key]["state"] == "done"
    status = st.board.status()
    assert status["counts"]["tracked"] == 1 and status["state"] == "stopped"
    assert st.board.passes()[-1]["key"] == o.key


def test_a_pass_runs_on_the_live_loop_and_parks(catalog):
    st = Station_(catalog, mode="stream")
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    (o,) = _done(report)
    assert o.mode == "stream" and o.commands > 10 and o.starts > 0 and o.travel_deg > 30
    assert o.measured_max_error_deg is not None and o.measured_max_error_deg < 6.0
    park_wire = f"{SPEC.park_az_deg:03.0f}".encode()
    assert b"W" + park_wire in st.wire      # parked after the pass


def test_a_restart_does_not_track_a_done_pass_again(catalog, tmp_path):
    state = tmp_path / "state.json"
    first = Station_(catalog, state_path=state)
    assert len(_done(first.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc)))) == 1
    # The service restarts while the pass would still be under way (its LOS not reached).
    again = Station_(catalog, state_path=state,
                     start=datetime(2026, 8, 22, 13, 6, tzinfo=timezone.utc))
    report = again.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert _done(report) == []
    assert again.said("recent pass outcome(s) picked up")
    assert b"T\r" not in again.wire and b"W" not in again.wire
    assert again.board.schedule()[0]["state"] == "done"


def test_a_controller_unplugged_for_the_whole_pass_fails_it_and_the_next_is_tracked(catalog):
    # NOAA 20 at 13:04 and FUNCUBE-1 at 14:22; the port is gone from 12:55 until 13:40.
    st = Station_(catalog, mode="stream", faults=("disconnect=2700@1",),
                  targets={"NOAA 20": 1, "FUNCUBE-1": 1})
    report = st.run_until(datetime(2026, 8, 22, 14, 40, tzinfo=timezone.utc))
    by_target = {o.target: o for o in report.outcomes if o.chosen}
    noaa, funcube = by_target["NOAA 20 (JPSS-1)"], by_target["FUNCUBE-1 (AO-73)"]
    assert noaa.outcome in ("failed", "skipped") and noaa.reason
    assert funcube.outcome == "done" and funcube.commands > 0
    assert st.board.status()["faults"]


def test_a_jammed_rotator_is_stopped_and_the_pass_failed(catalog):
    # the azimuth motor jams from 13:06 (660 s after the start) for good
    st = Station_(catalog, mode="stream", faults=("jam=az@660",))
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    (o,) = [o for o in report.outcomes if o.chosen]
    assert o.outcome == "failed" and o.reason.startswith("stall")
    assert b"S\r" in st.wire                 # all-stop reached the controller
    assert any("stall" in f["text"] for f in st.board.status()["faults"])


class _JumpingClock(LockstepClock):
    """A system clock set forward by hand while the service slept."""

    jump_s = 0.0

    def sleep(self, seconds: float) -> None:
        super().sleep(seconds)
        if self.jump_s:
            jump, self.jump_s = self.jump_s, 0.0
            self.advance(jump)


def test_a_clock_jump_replans_and_the_passes_jumped_over_are_skipped(catalog):
    clock = _JumpingClock(BEFORE_NOAA20)
    st = Station_(catalog, targets={"NOAA 20": 1, "FUNCUBE-1": 1}, clock=clock,
                  start=BEFORE_NOAA20)
    st.hooks.append(lambda text: setattr(clock, "jump_s", 3600.0)
                    if "schedule (start)" in text else None)
    report = st.run_until(datetime(2026, 8, 22, 14, 40, tzinfo=timezone.utc))
    assert st.said("the clock jumped +3600 s") and st.said("schedule (clock jump)")
    outcomes = {o.target: o for o in report.outcomes if o.chosen}
    assert outcomes["NOAA 20 (JPSS-1)"].outcome == "skipped"
    assert "missed" in outcomes["NOAA 20 (JPSS-1)"].reason
    assert outcomes["FUNCUBE-1 (AO-73)"].outcome == "done"


def test_a_reload_between_passes_takes_the_new_schedule(catalog):
    st = Station_(catalog, targets={"NOAA 20": 1})
    added = ScheduleSettings(targets={"NOAA 20": 1, "FUNCUBE-1": 1}, horizon_h=6.0)

    def reload() -> None:
        st.service.settings = added

    st.hooks.append(lambda text: st.service.request_reload(reload)
                    if "NOAA 20 (JPSS-1) done" in text else None)
    report = st.run_until(datetime(2026, 8, 22, 14, 40, tzinfo=timezone.utc))
    assert st.said("reloading the configuration") and st.said("schedule (configuration "
                                                              "reloaded)")
    assert [o.target for o in _done(report)] == ["NOAA 20 (JPSS-1)", "FUNCUBE-1 (AO-73)"]


def test_a_state_file_that_cannot_be_written_is_a_fault_not_the_end(catalog, tmp_path):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the state folder should be\n")
    st = Station_(catalog, state_path=blocker / "state.json")
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert len(_done(report)) == 1
    assert st.said("fault: could not write the pass log or state file")
    assert blocker.read_text().startswith("a file")          # nothing of the user's lost


def test_an_unreadable_state_file_is_set_aside(catalog, tmp_path):
    state = tmp_path / "state.json"
    state.write_text("{ not json")
    st = Station_(catalog, state_path=state)
    st.run_until(datetime(2026, 8, 22, 13, 1, tzinfo=timezone.utc))
    assert (tmp_path / "state.json.bad").read_text() == "{ not json"
    assert st.said("is unreadable")


class _SpyControl:
    """Stands in for the control port: records when the service hands the rotator out and
    takes it back, and what the controller had received by then."""

    def __init__(self, wire):
        self.wire = wire
        self.owner = "station"
        self.calls: list[tuple[str, int]] = []

    def hand_over(self) -> None:
        self.owner = "outside"
        self.calls.append(("hand_over", len(self.wire())))

    def take_back(self, reason: str) -> None:
        self.owner = "station"
        self.calls.append(("take_back", len(self.wire())))


def test_the_rotator_is_handed_out_between_passes_and_taken_back_before_each(catalog):
    st = Station_(catalog)
    spy = _SpyControl(st.bench.bytes_written)
    st.service.control = spy
    st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    kinds = [k for k, _n in spy.calls]
    assert kinds[0] == "hand_over" and "take_back" in kinds
    first_take = kinds.index("take_back")
    # nothing was sent to the controller before the station took the rotator back
    assert spy.calls[first_take][1] == 0 < len(st.wire)
    assert st.board.status()["state"] == "stopped"


def test_all_stop_during_a_pass_reaches_the_controller(catalog):
    st = Station_(catalog, mode="stream")
    sent: list[bool] = []
    set_target = st.board.set_target

    def interrupt_while_tracking(*args, **kw):
        set_target(*args, **kw)
        if not sent and st.board.status()["state"] == "tracking":
            sent.append(st.service.all_stop())
            raise KeyboardInterrupt      # what the session's signal handler raises

    st.board.set_target = interrupt_while_tracking
    with pytest.raises(KeyboardInterrupt):
        st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert sent == [True]
    assert st.wire.rstrip(b"\r").endswith(b"S")       # the last word on the wire is all-stop


def test_a_pass_not_chosen_at_first_is_tracked_once_a_reload_chooses_it(catalog, tmp_path):
    st = Station_(catalog, state_path=tmp_path / "state.json")
    st.service.settings = ScheduleSettings(targets={"NOAA 20": 1}, min_max_el_deg=45.0,
                                           horizon_h=6.0)     # NOAA 20 peaks at 42 deg
    lower = ScheduleSettings(targets={"NOAA 20": 1}, min_max_el_deg=10.0, horizon_h=6.0)

    def reload() -> None:
        st.service.settings = lower

    st.hooks.append(lambda text: st.service.request_reload(reload)
                    if "schedule (start)" in text else None)
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert [(o.target, o.chosen) for o in _done(report)] == [("NOAA 20 (JPSS-1)", True)]
    assert not [o for o in report.outcomes if o.key == _done(report)[0].key and not o.chosen]


def test_a_target_the_catalogue_does_not_know_stops_the_run_at_the_start(catalog):
    st = Station_(catalog, targets={"NOSUCHSAT": 1})
    with pytest.raises(ConfigError, match="NOSUCHSAT"):
        st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert not st.said("fault: schedule not recomputed")


def test_a_reload_naming_an_unknown_target_keeps_the_old_schedule(catalog):
    st = Station_(catalog, targets={"NOAA 20": 1})
    old = st.service.settings

    def reload() -> None:
        st.service.settings = ScheduleSettings(targets={"NOSUCHSAT": 1}, horizon_h=6.0)

    st.hooks.append(lambda text: st.service.request_reload(reload)
                    if "schedule (start)" in text else None)
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert st.said("fault: configuration not reloaded, the old one stays: [schedule] "
                   "targets: no satellite 'NOSUCHSAT'")
    assert st.service.settings is old
    assert [o.target for o in _done(report)] == ["NOAA 20 (JPSS-1)"]
    assert not st.said("schedule not recomputed")


class _SlowKeeper:
    """An element keeper whose refresh takes a second of the clock (a download)."""

    def __init__(self, catalog, clock):
        self._catalog, self.clock, self.events = catalog, clock, None
        self._done = False

    def due(self) -> bool:
        return not self._done

    def refresh(self) -> bool:
        self._done = True
        self.clock.sleep(1.0)
        return False

    def ages(self, _now):
        return []

    def catalog(self):
        return self._catalog


def test_the_first_schedule_is_computed_once_when_the_refresh_takes_time(catalog):
    st = Station_(catalog)
    st.service.keeper = _SlowKeeper(catalog, st.clock)
    st.run_until(datetime(2026, 8, 22, 12, 57, tzinfo=timezone.utc))
    assert len(st.said("schedule (")) == 1, st.said("schedule (")


def test_state_file_entries_of_the_wrong_shape_are_dropped_not_a_crash(catalog, tmp_path):
    state = tmp_path / "state.json"
    odd = {"text": {"state": "done", "los_s": "x"}, "inf": {"state": "done", "los_s": 1e999},
           "reason": {"state": "done", "reason": 3}, "bool": {"state": "done", "los_s": True}}
    state.write_text(json.dumps({"version": 1, "passes": odd}).replace("Infinity", "1e999"))
    st = Station_(catalog, state_path=state)
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert len(_done(report)) == 1
    assert not set(odd) & set(json.loads(state.read_text())["passes"])


def test_a_huge_state_file_is_set_aside_and_an_earlier_one_set_aside_is_kept(catalog, tmp_path):
    state = tmp_path / "state.json"
    (tmp_path / "state.json.bad").write_text("set aside before\n")
    state.write_text(json.dumps({"version": 1, "passes": {}}) + " " * 5_000_000)
    st = Station_(catalog, state_path=state)
    st.run_until(datetime(2026, 8, 22, 13, 1, tzinfo=timezone.utc))
    assert st.said("larger than 4,000,000 bytes")
    assert (tmp_path / "state.json.bad").read_text() == "set aside before\n"
    assert (tmp_path / "state.json.bad.1").stat().st_size > 5_000_000


@pytest.mark.parametrize("targets, min_el_deg, why", [
    ({"NOAA 20": 1}, 89.9, "pass(es) of the targets left out, e.g. NOAA 20 (JPSS-1): max el"),
    ({"43700": 1}, 10.0, "always up like a geostationary satellite"),     # QO-100, always up
])
def test_a_schedule_without_a_pass_says_so_and_why(catalog, targets, min_el_deg, why):
    st = Station_(catalog, targets=targets)
    st.service.settings = ScheduleSettings(targets=targets, min_max_el_deg=min_el_deg,
                                           horizon_h=6.0)
    report = st.run_until(datetime(2026, 8, 22, 13, 0, tzinfo=timezone.utc))
    assert [o for o in report.outcomes if o.chosen] == []
    line = st.said("schedule (start)")[0]
    assert "no pass in the schedule" in line and why in line, line


def test_a_state_file_is_held_by_one_run_at_a_time(tmp_path):
    from tracker.service.records import state_lock

    state = tmp_path / "state.json"
    with state_lock(state):
        with pytest.raises(ConfigError, match="in use by another station run"), \
                state_lock(state):
            pass
    with state_lock(state):          # released at the end of the first
        pass


def test_a_pass_joined_under_way_counts_its_error_from_acquisition(catalog):
    # the station starts 5 min after NOAA 20's AOS, the antenna parked far from it
    st = Station_(catalog, mode="stream", start=datetime(2026, 8, 22, 13, 10,
                                                           tzinfo=timezone.utc))
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    (o,) = _done(report)
    assert o.reason.startswith("joined 3") and "on target" in o.reason
    assert o.measured_max_error_deg is not None and o.measured_max_error_deg < 6.0


def test_a_pass_skipped_for_a_rival_and_chosen_later_is_tracked(catalog, tmp_path):
    # FENGYUN 3D (12:59-13:13, priority 5) wins the overlap with NOAA 20 (13:04-13:19): NOAA
    # 20 is left out ("overlaps FENGYUN 3D"). A reload drops the rival before either pass, so
    # the next schedule chooses NOAA 20: it is tracked, not kept as the earlier skip.
    state = tmp_path / "state.json"
    st = Station_(catalog, mode="stream", targets={"NOAA 20": 1, "FENGYUN 3D": 5},
                  start=datetime(2026, 8, 22, 12, 30, tzinfo=timezone.utc), state_path=state)
    alone = ScheduleSettings(targets={"NOAA 20": 1}, mode="stream", horizon_h=6.0)
    key = "43013-20260822T130450Z"
    first: list[str] = []

    def reload() -> None:
        first.extend(e["reason"] for e in st.board.schedule() if e["key"] == key)
        st.service.settings = alone

    st.hooks.append(lambda text: st.service.request_reload(reload)
                    if "schedule (start)" in text else None)
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    assert first and first[0].startswith("overlaps FENGYUN 3D")
    assert [(o.outcome, o.chosen) for o in report.outcomes if o.key == key] == [("done", True)]
    assert StationState.load(state)[0].passes[key]["state"] == "done"
    assert [e["state"] for e in st.board.schedule() if e["key"] == key] == ["done"]


def test_a_table_pass_joined_under_way_resumes_from_the_point_due(catalog):
    # the station starts 5 min after NOAA 20's AOS: the table steps from the point due then
    st = Station_(catalog, mode="table", start=datetime(2026, 8, 22, 13, 10,
                                                          tzinfo=timezone.utc))
    report = st.run_until(datetime(2026, 8, 22, 13, 25, tzinfo=timezone.utc))
    (o,) = _done(report)
    assert o.reason.startswith("joined 3") and "on target" in o.reason
    assert o.measured_max_error_deg is not None and o.measured_max_error_deg < 2.0
    assert not st.said("resync")          # started on the point due, not caught up later
