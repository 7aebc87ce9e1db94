"""Golden byte transcripts of the byte-oriented controllers (Rotor-EZ, DCU-1, SAK-232,
GS-232B-AZ/AZ): the emulator reproduces them exactly in-process, over a real TCP socket and
over a real pty. Files are ``tests/data/transcripts/*.transcript`` (the GS-232 ``*.txt``
ones belong to test_gs232_transcripts.py)."""

from __future__ import annotations

from datetime import datetime

import pytest
from _gs232_helpers import T0, TRANSCRIPTS, load_transcript, replay_over_real_io

from tracker.clock import ManualClock
from tracker.emulator import serve_pty, serve_tcp
from tracker.emulator.rotorez_controller import HAM_IV, RotorEzController

FILES = sorted(TRANSCRIPTS.glob("*.transcript"))


def _controller(tr):
    clock = ManualClock(datetime.fromisoformat(T0))
    if tr.profile in ("rotorez", "dcu1"):
        assert tr.rotator == "HAM-IV"
        return RotorEzController(tr.profile, HAM_IV, clock), clock
    if tr.profile.startswith("sak232"):
        from tracker.emulator.sak232_controller import Sak232Controller, Sak232Options

        assert tr.rotator == "Zelpro-RAU"
        opts = Sak232Options(gs23=tr.profile.endswith("-gs23"))
        return Sak232Controller(clock=clock, options=opts), clock
    if tr.profile == "gs232b-azaz":
        from tracker.emulator.azaz_controller import AzAzController

        return AzAzController(clock=clock), clock
    raise AssertionError(f"unknown profile {tr.profile}")


def test_all_four_transcripts_exist():
    assert {p.stem for p in FILES} >= {"rotorez", "dcu1", "sak232", "azaz"}


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_transcript_in_process(path):
    tr = load_transcript(path)
    ctrl, clock = _controller(tr)
    session = ctrl.open_session()
    for i, step in enumerate(tr.steps):
        if step[0] == "advance":
            clock.advance(step[1])
            continue
        _, req, expected = step
        assert session.feed(req) == expected, f"{path.name} step {i}: {req!r}"


def _expected_counts(tr) -> list[int]:
    """commands_seen after each send step, from an in-process twin of the controller."""
    twin, clock = _controller(tr)
    s = twin.open_session()
    counts = []
    for step in tr.steps:
        if step[0] == "advance":
            clock.advance(step[1])
        else:
            s.feed(step[1])
            counts.append(twin.commands_seen)
    return counts


@pytest.mark.parametrize("kind", ["tcp", "pty"])
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_transcript_over_real_io(path, kind):
    tr = load_transcript(path)
    ctrl, clock = _controller(tr)
    counts = iter(_expected_counts(tr))
    server = serve_tcp(ctrl) if kind == "tcp" else serve_pty(ctrl)
    try:
        replay_over_real_io(tr, ctrl, clock, server, path.name,
                            lambda _seen, _req: next(counts))
    finally:
        server.close()
    assert server.closed and not server.thread.is_alive()
