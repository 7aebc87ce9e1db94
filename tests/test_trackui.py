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


def test_ctrl_c_on_the_live_panel_is_not_echoed_and_the_echo_comes_back(tmp_path):
    """The panel's last line fills the terminal, so an echoed ``^C`` wrapped to a new line
    and the panel's top border was drawn twice. A real terminal (pty) and a real Ctrl-C: the
    run stops (exit 130, "interrupted"), no ``^C`` is echoed, and the echo is on again after."""
    import fcntl
    import os
    import pty
    import select
    import signal
    import struct
    import sys
    import termios
    import time

    from _paths import REPO

    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"), TERM="xterm-256color",
               XDG_CONFIG_HOME=str(tmp_path / "config"), PYTHONPATH=str(REPO), COLUMNS="100",
               LINES="30")
    env.pop("TRACKER_CONFIG", None)
    pid, master = pty.fork()
    if pid == 0:    # the child: the pty is its controlling terminal, so ^C is a SIGINT
        # A suite started as a background job inherits SIGINT ignored (exec keeps that); a
        # user at a terminal has it on.
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.execve(sys.executable, [sys.executable, "-m", "tracker", "track", "ISS (ZARYA)"],
                  env)
    fcntl.ioctl(master, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))

    def read_until(marker: bytes | None, timeout_s: float) -> bytes:
        out = b""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and (marker is None or marker not in out):
            if select.select([master], [], [], 0.2)[0]:
                try:
                    chunk = os.read(master, 65536)
                except OSError:          # the child is gone: the pty is closed
                    break
                if not chunk:
                    break
                out += chunk
        return out

    try:
        before = read_until("╭".encode(), 120.0)       # the panel is up
        assert "╭".encode() in before, before[-2000:]
        os.write(master, b"\x03")
        after = read_until(None, 120.0)
        echo_back = termios.tcgetattr(master)[3] & termios.ECHO
    finally:
        end = time.monotonic() + 30.0
        while (done := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < end:
            time.sleep(0.05)
        if done[0] == 0:             # never hang the suite on a stuck child
            os.kill(pid, 9)
            done = os.waitpid(pid, 0)
        status = done[1]
        os.close(master)
    assert os.waitstatus_to_exitcode(status) == 130, after[-2000:]
    assert b"interrupted" in after, after[-2000:]
    assert b"^C" not in after
    assert echo_back
