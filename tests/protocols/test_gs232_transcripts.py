"""Golden byte transcripts: the emulator reproduces them exactly, in-process, over a real TCP
socket and over a real pty."""

from __future__ import annotations

from datetime import datetime

import pytest
from _gs232_helpers import T0, TRANSCRIPTS, load_transcript, replay_over_real_io

from tracker.clock import ManualClock
from tracker.emulator import Gs232Controller, serve_pty, serve_tcp
from tracker.mount import preset

FILES = sorted(TRANSCRIPTS.glob("*.txt"))


def _controller(tr):
    clock = ManualClock(datetime.fromisoformat(T0))
    return Gs232Controller(tr.profile, preset(tr.rotator), clock), clock


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


@pytest.mark.parametrize("kind", ["tcp", "pty"])
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_transcript_over_real_io(path, kind):
    tr = load_transcript(path)
    ctrl, clock = _controller(tr)
    server = serve_tcp(ctrl) if kind == "tcp" else serve_pty(ctrl)
    try:
        replay_over_real_io(tr, ctrl, clock, server, path.name,
                            lambda seen, req: seen + req.count(b"\r"))
    finally:
        server.close()
    assert server.closed and not server.thread.is_alive()
