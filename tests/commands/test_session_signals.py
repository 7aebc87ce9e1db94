"""Every way out of a rotator-moving command ends with all-stop as the last command on the wire.

One test per command x signal x phase: the CLI runs as a subprocess (``python -m tracker``)
against the project's emulator served on a real TCP socket; the test waits for the phase by
polling the child's output or the emulator's log, sends SIGINT, SIGTERM or SIGHUP, and reads
the emulator's log: the child must exit (130, "interrupted (SIG...)", no traceback) and the
controller's last command must be ``S``, with the antenna standing still.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from datetime import datetime
from pathlib import Path

import pytest
from _gs232_helpers import wait_until
from _paths import REPO
from _rigs import default_signals

from tracker.clock import SimClock, SystemClock
from tracker.config import load_config
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.trackui import PHASE_WORDS

SIGNALS = [signal.SIGINT, signal.SIGTERM, signal.SIGHUP]
PHASE_TIMEOUT_S = 90.0      # generous: the machine may be loaded
EXIT_TIMEOUT_S = 30.0

# A G-5500 that parks at the far end of its travel: after LOS the park slew takes about a
# simulated minute, long enough to signal the child while it parks.
CONFIG = """
[rotator.farpark]
preset = "G-5500"
park_az_deg = 440
"""
# ISS (ZARYA) over the default station with the bundled elements: AOS ~02:07:45, LOS
# ~02:17:04; the pre-position starts a few simulated seconds after this.
TRACK_AT = "2026-08-23T02:06:05Z"
TRACK_SPEED = 20.0
# The phases defined by a slew last as long as the slew: at 20x a minute-long park is 3 s of
# wall time, which a child starved by a loaded machine can miss entirely; at 5x it is 12 s.
PHASE_SPEED = {"preposition": 5.0, "park": 5.0}


class Child:
    """``python -m tracker ARGV`` with its stdout and stderr collected as they come."""

    def __init__(self, argv: list[str], config: Path):
        env = dict(os.environ, TRACKER_CONFIG=str(config),
                   PYTHONPATH=os.pathsep.join(p for p in (str(REPO),
                                                          os.environ.get("PYTHONPATH")) if p))
        self.proc = subprocess.Popen([sys.executable, "-m", "tracker", *argv],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env=env, preexec_fn=default_signals())
        self.out: list[str] = []
        self.err: list[str] = []
        self._readers = [threading.Thread(target=self._drain, args=(s, sink), daemon=True)
                         for s, sink in ((self.proc.stdout, self.out),
                                         (self.proc.stderr, self.err))]
        for t in self._readers:
            t.start()

    @staticmethod
    def _drain(stream, sink: list[str]) -> None:
        for line in stream:
            sink.append(line)

    def said(self, text: str) -> bool:
        return any(text in line for line in list(self.out))

    def wait_for(self, pred, what: str) -> None:
        ok = wait_until(lambda: pred() or self.proc.poll() is not None, PHASE_TIMEOUT_S)
        assert ok and self.proc.poll() is None, (
            f"the child never reached {what} (exit {self.proc.poll()}):\n"
            + "".join(self.out[-15:]) + "".join(self.err[-15:]))

    def stop_with(self, sig: int) -> int:
        self.proc.send_signal(sig)
        rc = self.proc.wait(timeout=EXIT_TIMEOUT_S)
        for t in self._readers:
            t.join(5)
        return rc

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)


def _lines(ctrl) -> list[bytes]:
    return [line.strip() for _t, line, _r in ctrl.log]


def _moves_sent(ctrl) -> list[bytes]:
    return [ln for ln in _lines(ctrl) if ln[:1] in (b"W", b"M")]


def _assert_stopped_last(child: Child, rc: int, sig: int, ctrl) -> None:
    err = "".join(child.err)
    assert rc == 130, (rc, "".join(child.out[-10:]), err)
    assert f"interrupted ({signal.Signals(sig).name})" in err, err
    assert "Traceback" not in err, err
    # The all-stop needs no reply: give the emulator thread a moment to read it.
    assert wait_until(lambda: ctrl.log and ctrl.log[-1][1].strip() == b"S", 3.0), \
        _lines(ctrl)[-6:]
    assert not ctrl.moving()


@pytest.fixture
def config(tmp_path) -> Path:
    path = tmp_path / "tracker.toml"
    path.write_text(CONFIG)
    return path


# tracker track ----------------------------------------------------------------------------

TRACK_PHASES = {
    # phase: (the line the child prints when it is in it, must the antenna be turning)
    "wait": ("mode ", False),      # planned, waiting minutes for the pre-position time
    "preposition": (f"  {PHASE_WORDS['preposition']}\n", True),
    "track": (f"  {PHASE_WORDS['track']}\n", False),
    "park": (f"  {PHASE_WORDS['park']}\n", True),
}
WAIT_AT = "2026-08-23T02:00:00Z"   # the pre-position starts 6 simulated minutes later
PARK_AT = "2026-08-23T02:16:00Z"   # joins the pass a minute before LOS, then parks


@pytest.mark.parametrize("phase", list(TRACK_PHASES))
@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_track_signal_ends_with_all_stop_last(sig, phase, config):
    spec = load_config(str(config)).rotator("farpark")
    at = {"wait": WAIT_AT, "park": PARK_AT}.get(phase, TRACK_AT)
    speed = PHASE_SPEED.get(phase, TRACK_SPEED)
    clock = SimClock(datetime.fromisoformat(at.replace("Z", "+00:00")), speed)
    ctrl = Gs232Controller("gs232b", spec, clock=clock)
    server = serve_tcp(ctrl)
    child = Child(["track", "ISS (ZARYA)", "--port", server.url, "--rotator", "farpark",
                   "--at", at, "--speed", str(speed), "--plain"], config)
    try:
        line, turning = TRACK_PHASES[phase]
        child.wait_for(lambda: child.said(line) and (ctrl.moving() or not turning),
                       f"phase {phase}")
        if phase == "wait":
            assert b"C2" in _lines(ctrl) and _moves_sent(ctrl) == []
        rc = child.stop_with(sig)
        _assert_stopped_last(child, rc, sig, ctrl)
    finally:
        child.kill()
        server.close()


# tracker upload --port ----------------------------------------------------------------------

UPLOAD_START = "2026-08-23T02:00:00"
UPLOAD_T_S = 6            # T this many seconds after the start; point 1 is sent at +0.5 s
UPLOAD_POINTS = 40        # one a second after T: the table steps for 40 s


def _plan_file(path: Path) -> Path:
    """A one-table plan: az 10..49, el 5..44, one point a second from T."""
    pts = [(10 + i, 5 + i) for i in range(UPLOAD_POINTS)]
    t_utc = f"{UPLOAD_START[:-2]}{UPLOAD_T_S:02d}.000Z"
    path.write_text(
        "# profile: gs232b\n# rotator: G-5500\n# target: test\n"
        f"# table 1/1 points={len(pts)} upload_utc={UPLOAD_START}.500Z "
        f"arrive_utc={UPLOAD_START}.700Z t_utc={t_utc}\n"
        "W001 " + " ".join(f"{a:03d} {e:03d}" for a, e in pts) + "\nT\n")
    return path


UPLOAD_PHASES = {
    # phase: the last command the controller must have received
    "preposition": lambda lines: any(ln.startswith(b"W001") for ln in lines),
    "stepping": lambda lines: b"T" in lines,
}


@pytest.mark.parametrize("phase", list(UPLOAD_PHASES))
@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_upload_signal_ends_with_all_stop_last(sig, phase, config, tmp_path):
    plan = _plan_file(tmp_path / "table.steps")
    ctrl = Gs232Controller("gs232b", clock=SystemClock(), az_deg=0, el_deg=0)
    server = serve_tcp(ctrl)
    child = Child(["upload", "--from", str(plan), "--port", server.url,
                   "--at", f"{UPLOAD_START}Z"], config)
    try:
        seen = UPLOAD_PHASES[phase]
        child.wait_for(lambda: seen(_lines(ctrl)) and ctrl.moving(), f"phase {phase}")
        if phase == "preposition":
            assert b"T" not in _lines(ctrl)
        rc = child.stop_with(sig)
        _assert_stopped_last(child, rc, sig, ctrl)
    finally:
        child.kill()
        server.close()


# tracker rotator ----------------------------------------------------------------------------


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_rotator_signal_while_waiting_for_a_reply_ends_with_all_stop(sig, config):
    ctrl = Gs232Controller("gs232b", clock=SystemClock(), az_deg=100, el_deg=20)
    ctrl.open_session().feed(b"W300 060\r")   # turning when the command starts
    ctrl.faults.silent = True          # reads and acts on commands, never answers
    server = serve_tcp(ctrl)
    child = Child(["rotator", "--port", server.url, "--timeout", "60", "position"], config)
    try:
        child.wait_for(lambda: b"C2" in _lines(ctrl), "the position query")
        assert ctrl.moving()
        rc = child.stop_with(sig)
        _assert_stopped_last(child, rc, sig, ctrl)
    finally:
        child.kill()
        server.close()


def test_rotator_position_leaves_a_started_move_running(config):
    """The session stops on a signal or an error, not on a normal end: a rotctl-like
    ``position`` while a goto runs must not stop it."""
    ctrl = Gs232Controller("gs232b", clock=SystemClock(), az_deg=100, el_deg=20)
    ctrl.open_session().feed(b"W300 060\r")
    server = serve_tcp(ctrl)
    try:
        child = Child(["rotator", "--port", server.url, "position"], config)
        assert child.proc.wait(timeout=EXIT_TIMEOUT_S) == 0, "".join(child.err)
        assert b"S" not in _lines(ctrl) and ctrl.moving()
    finally:
        server.close()


# Effective limits before planning: tracker track through a real rotctld ---------------------


@pytest.mark.hamlib
@pytest.mark.slow
def test_track_through_rotctld_plans_inside_its_elevation_limit(tmp_path):
    """Hamlib's dummy rotator (``rotctld -m 1``) takes elevation 0..90. A near-overhead pass
    that the default G-5500 (0-180) would follow as a keyhole over the top is planned inside
    0..90 instead, upright (it used to plan el 0-180 and abort before AOS on the first move
    above 90).
    SIGTERM then ends the run the Ctrl-C way."""
    from _rigs import ROTCTLD, start_rotctld

    if ROTCTLD is None:
        pytest.skip("Hamlib rotctld not installed")
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    proc, port = start_rotctld("-m", "1")
    # ISS 05:19:52-05:30:43, max el 86.5: the G-5500 plan is a keyhole sweep el 0-180.
    child = Child(["track", "ISS (ZARYA)", "--protocol", "rotctld", "--port",
                   f"127.0.0.1:{port}", "--at", "2026-08-23T05:17:00Z", "--speed", "5",
                   "--plain"], empty)
    try:
        child.wait_for(lambda: child.said("mode "), "the plan")
        text = "".join(child.out)
        assert "planning inside the controller's limits: az 0-450, el 0-90" in text, text
        mode = next(ln for ln in child.out if "mode " in ln).split("mode ")[1]
        # Upright: the exact path, or one turning its azimuth early (the exact one loses 9 s).
        assert mode.startswith(("normal", "overlap", "ahead")) and "flipped" not in mode, mode
        rc = child.stop_with(signal.SIGTERM)
        err = "".join(child.err)
        assert rc == 130 and "interrupted (SIGTERM)" in err and "outside" not in err, err
    finally:
        child.kill()
        proc.terminate()
        proc.wait(5)
