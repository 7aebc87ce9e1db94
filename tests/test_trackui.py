"""The live loop's output sinks fed by a real pass on virtual time: the terminal panel (rich)
and the plain lines show the phase, the pointing and the events the loop reported."""

from __future__ import annotations

import io
import re
from datetime import datetime, timezone

from test_stream_e2e import Bench

from tracker.clock import ManualClock
from tracker.trackui import Fanout, PlainLines, RichPanel


def _run_into(b: Bench, *sinks, close: bool = True):
    fan = Fanout(*sinks)
    on_status, event = b.on_status, b.event

    def status(st):
        on_status(st)
        fan.status(st)

    def both(kind, **data):
        event(kind, **data)
        fan.event(kind, **data)
    b.on_status, b.event = status, both
    res = b.run()
    if close:
        fan.close()
    return b, res


def test_rich_panel_shows_the_last_cycle_and_events(capsys):
    b = Bench("emu")
    panel = RichPanel(b.clock, "ISS (ZARYA)", banner="SIMULATION", next_pass="02:07 UTC")
    panel.event("info", text="hello")
    _b, res = _run_into(b, panel)
    assert res.completed
    out = capsys.readouterr().out
    for text in ("ISS (ZARYA)", "SIMULATION", "phase / mode", "pass over", "commanded",
                 "antenna", "error", "next pass", "02:07 UTC"):
        assert text in out, text
    assert "all-stop" in out or "park" in out     # the last events are listed


def test_plain_lines_report_each_phase_and_the_status():
    out = io.StringIO()
    b = Bench("emu")
    plain = PlainLines(b.clock, stream=out, every_s=10.0)
    _b, res = _run_into(b, plain)
    assert res.completed
    text = out.getvalue()
    for phase in ("preposition", "track", "park", "done"):
        assert phase in text, phase
    assert "target az" in text and "antenna az" in text and "cmds" in text


def _panel_text(panel: RichPanel) -> str:
    return "\n".join(line.rstrip() for line in panel.console.export_text().splitlines())


def _recording_panel(**kw) -> RichPanel:
    from rich.console import Console

    console = Console(record=True, width=100, height=60, force_terminal=False)
    return RichPanel(ManualClock(datetime(2026, 8, 23, 2, 5, tzinfo=timezone.utc)),
                     "tracker track ISS (ZARYA)", console=console,
                     **kw)


def test_panel_header_keeps_the_simulation_notes_the_date_the_plan_and_the_result():
    b = Bench("emu")
    panel = _recording_panel(banner="SIMULATION: built-in emulator",
                             header=("the elements are 94 days old: a replayed pass",))
    panel.event("info", topic="plan", text="pass 1: ISS mode normal: it fits")
    panel.clock = b.clock
    _b, res = _run_into(b, panel, close=False)
    panel.event("info", topic="result", text="pass 1 done: 20 commands")
    for n in range(10):
        panel.event("info", text=f"a later event {n}")
    panel.close()
    text = _panel_text(panel)
    assert res.completed
    assert "SIMULATION" in text and "94 days old" in text
    assert re.search(r"time  20\d\d-\d\d-\d\d \d\d:\d\d:\d\d UTC", text), text
    assert "pass 1: ISS mode normal" in text and "pass 1 done: 20 commands" in text
    assert text.count("╭") == 1


def test_panel_height_stays_fixed_however_long_the_events():
    def height(*events: str) -> int:
        panel = _recording_panel(banner="SIMULATION")
        for e in events:
            panel.event("info", text=e)
        panel.close()
        return len(_panel_text(panel).splitlines())

    assert height("short") == height("long " * 80, "longer " * 90) == height()


def test_panel_says_connected_once_the_events_do():
    panel = _recording_panel()
    panel.event("state", state="connected")
    panel.close()
    text = _panel_text(panel)
    assert "connecting" not in text and "connected" in text


def test_plain_lines_use_words_not_state_names():
    out = io.StringIO()
    plain = PlainLines(ManualClock(datetime(2026, 8, 23, 2, 5, tzinfo=timezone.utc)), stream=out)
    plain.event("state", state="start", target="ISS")
    plain.event("state", state="plan", mode="normal")
    plain.event("state", state="phase", phase="preposition")
    plain.event("state", state="pass_done", commands=3)
    plain.event("command", cmd="goto", az=20.0, az_m=380.0, bearing=20.0, el=None,
                reason="track")
    text = out.getvalue()
    assert "state" not in text and "pass_done" not in text
    assert "moving to the AOS point" in text
    assert "az  20.0 (mech 380)" in text
