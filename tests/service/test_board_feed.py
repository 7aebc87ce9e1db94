"""``BoardFeed``: the live loop's status records and events onto the StatusBoard, alone and
beside the loop's other outputs in a Fanout during a real pass on virtual time."""

from __future__ import annotations

import dataclasses

from _virtual import manual_clock, virtual_rig

from tracker.api import (
    Catalog,
    Station,
    StreamSettings,
    driver_limits,
    follow_passes,
    make_controller,
    next_pass,
    open_driver,
    preset,
    resolve_target,
    utc,
)
from tracker.clock import ManualClock
from tracker.service.board import BoardFeed, StatusBoard
from tracker.stream import Phase, Status
from tracker.trackui import Fanout


def status(**kw) -> Status:
    base = dict(t_s=0.0, phase=Phase.TRACK, mode="normal", target_az_deg=370.0,
                target_el_deg=20.0, antenna_az_m_deg=365.0, antenna_el_deg=19.0,
                antenna_bearing_deg=5.0, command_az_m_deg=None, command_el_deg=None,
                error_deg=1.234, aos_s=0.0, los_s=600.0, progress=0.5, commands=3)
    base.update(kw)
    return Status(**base)


def fresh() -> tuple[StatusBoard, BoardFeed]:
    b = StatusBoard(ManualClock(utc(2026, 8, 22, 12)))
    return b, BoardFeed(b, preset("G-5500"), target="ISS (ZARYA)")


def test_status_sets_the_antenna_as_a_bearing_and_the_target():
    b, feed = fresh()
    feed.status(status())
    st = b.status()
    assert st["antenna"]["az_deg"] == 5.0 and st["antenna"]["el_deg"] == 19.0
    assert st["target"] == {"name": "ISS (ZARYA)", "az_deg": 10.0, "el_deg": 20.0,
                            "error_deg": 1.23}
    # no bearing in the record: the spec turns the mechanical azimuth into one
    feed.status(status(antenna_bearing_deg=None, antenna_az_m_deg=400.0))
    assert b.status()["antenna"]["az_deg"] == 40.0
    feed.status(status(antenna_bearing_deg=None, antenna_az_m_deg=None))
    assert b.status()["antenna"] is None


def test_an_azimuth_only_rotator_has_no_antenna_elevation():
    b = StatusBoard(ManualClock(utc(2026, 8, 22, 12)))
    az_only = dataclasses.replace(preset("G-5500"), el_max_deg=None, el_rate_deg_s=None)
    BoardFeed(b, az_only).status(status())
    assert b.status()["antenna"]["el_deg"] is None


def test_the_target_name_falls_back_to_the_current_pass():
    b = StatusBoard(ManualClock(utc(2026, 8, 22, 12)))
    feed = BoardFeed(b)
    feed.status(status())
    assert b.status()["target"]["name"] == "target"
    b.set_current_pass({"key": "k", "target": "NOAA 19", "path": []})
    feed.status(status())
    assert b.status()["target"]["name"] == "NOAA 19"


def test_phases_become_states():
    b, feed = fresh()
    seen = []
    for phase in ("wait", "preposition", "track", "park", "done"):
        feed.event("state", state="phase", phase=phase)
        st = b.status()
        seen.append((st["state"], st["detail"]))
    assert seen == [("idle", "waiting for the pass"),
                    ("prepositioning", "moving to the AOS point: ISS (ZARYA)"),
                    ("tracking", "tracking: ISS (ZARYA)"), ("parking", "parking: ISS (ZARYA)"),
                    ("idle", "pass over")]


def test_faults_are_logged_and_the_serious_ones_set_the_fault_state():
    b, feed = fresh()
    feed.event("state", state="phase", phase="track")
    feed.event("state", state="contradiction", note="read-back jumped")
    assert b.status()["state"] == "tracking"          # logged only: no event when it clears
    feed.event("state", state="port_lost", note="device gone")
    assert (b.status()["state"], b.status()["detail"]) == ("fault", "port lost: device gone")
    feed.event("state", state="reconnect_failed", note="no such file")
    feed.event("state", state="no_reply", note="timeout", count=1)     # routine: not a fault
    feed.event("state", state="reconnected", note="port back after 3.0 s")
    st = b.status()
    assert (st["state"], st["detail"]) == ("tracking", "reconnected: port back after 3.0 s")
    feed.event("state", state="stall", note="azimuth did not move")
    feed.event("command", cmd="stop")
    feed.event("reply", az=1.0, el=2.0)
    feed.event("info", text="pass 1 done")
    st = b.status()
    assert st["state"] == "fault" and st["detail"] == "stall: azimuth did not move"
    assert [f["text"] for f in st["faults"]] == [
        "read-back disagrees: read-back jumped", "port lost: device gone",
        "reconnect failed: no such file", "stall: azimuth did not move"]
    assert all(f["utc"] == "2026-08-22T12:00:00Z" for f in st["faults"])


def test_a_real_pass_in_a_fanout_moves_the_board():
    """follow_passes on the emu:// GS-232B and a ManualClock: the board sees every phase and
    ends with the antenna where the rotator really is."""
    station = Station("Delft", 52.0, 4.37, 10.0, min_el_deg=5.0)
    iss = resolve_target("ISS (ZARYA)", Catalog.bundled_snapshot())
    spec = preset("G-5500")
    first = next_pass(iss, station, utc(2026, 8, 22, 12).timestamp())
    clock = manual_clock(first.aos.timestamp() - 120.0)
    rig = virtual_rig(make_controller("gs232b", clock, rotator="G-5500"))
    b = StatusBoard(clock, simulated=True)
    feed = BoardFeed(b, spec, target=iss.name)
    states: list[str] = []
    antennas: list[float] = []

    class Watch:
        def event(self, kind, **data):
            if kind == "state" and data.get("state") == "phase":
                states.append(b.status()["state"])

        def status(self, st):
            antennas.append(b.status()["antenna"]["az_deg"])

        def close(self):
            pass

    out = Fanout(feed, Watch())
    try:
        res = follow_passes(iss, lambda: open_driver(rig.url, "gs232b", clock=clock,
                                                     **driver_limits(spec)),
                            spec, station, clock, StreamSettings(cycle_s=2.0), first=first,
                            events=out.event, on_status=out.status)
        bearing_now = float(spec.bearing_of(rig.ctl.antenna()[0]))
    finally:
        rig.close()
    assert res and res[0].completed
    assert states[:3] == ["prepositioning", "tracking", "parking"], states
    assert len(set(antennas)) > 20                  # it moved, cycle after cycle
    st = b.status()
    assert st["faults"] == [] and st["target"]["name"] == "ISS (ZARYA)"
    assert st["antenna"]["utc"] == st["now_utc"]    # the last read-back, on the loop's clock
    assert abs((st["antenna"]["az_deg"] - bearing_now + 180) % 360 - 180) <= 1.5
