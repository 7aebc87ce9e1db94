"""The live loop's output sinks fed by a real pass on virtual time: the terminal panel (rich)
and the plain lines show the phase, the pointing and the events the loop reported."""

from __future__ import annotations

import io

from test_stream_e2e import Bench

from tracker.trackui import Fanout, PlainLines, RichPanel


def _run_into(b: Bench, *sinks):
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
    fan.close()
    return b, res


def test_rich_panel_shows_the_last_cycle_and_events(capsys):
    b = Bench("emu")
    panel = RichPanel(b.clock, "ISS (ZARYA)", banner="SIMULATION", next_pass="02:07 UTC")
    panel.event("info", text="hello")
    _b, res = _run_into(b, panel)
    assert res.completed
    out = capsys.readouterr().out
    for text in ("ISS (ZARYA)", "SIMULATION", "phase / mode", "done", "commanded",
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
