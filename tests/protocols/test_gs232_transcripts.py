"""Golden byte transcripts: the emulator reproduces them exactly, in-process, over a real TCP
socket and over a real pty."""

from __future__ import annotations

import os
import select
import socket
import time
from datetime import datetime

import pytest
from _gs232_helpers import T0, TRANSCRIPTS, load_transcript, wait_until

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


def _read_exact(read, n: int, timeout_s: float = 2.0) -> bytes:
    out = b""
    end = time.monotonic() + timeout_s
    while len(out) < n and time.monotonic() < end:
        out += read(n - len(out))
    return out


@pytest.mark.parametrize("kind", ["tcp", "pty"])
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_transcript_over_real_io(path, kind):
    tr = load_transcript(path)
    ctrl, clock = _controller(tr)
    server = serve_tcp(ctrl) if kind == "tcp" else serve_pty(ctrl)
    try:
        if kind == "tcp":
            host, port = server.url.removeprefix("socket://").split(":")
            sock = socket.create_connection((host, int(port)), timeout=2)
            fileno, write, close = sock.fileno(), sock.sendall, sock.close

            def read(n):
                r, _, _ = select.select([fileno], [], [], 0.1)
                return sock.recv(n) if r else b""
        else:
            fd = os.open(server.url, os.O_RDWR | os.O_NOCTTY)
            fileno, close = fd, (lambda: os.close(fd))

            def write(b):
                os.write(fd, b)

            def read(n):
                r, _, _ = select.select([fd], [], [], 0.1)
                return os.read(fd, n) if r else b""
        try:
            for i, step in enumerate(tr.steps):
                if step[0] == "advance":
                    clock.advance(step[1])
                    continue
                _, req, expected = step
                seen = ctrl.commands_seen
                write(req)
                # a silent command must be processed before the clock moves on
                want = seen + req.count(b"\r")
                assert wait_until(lambda w=want: ctrl.commands_seen >= w)
                got = _read_exact(read, len(expected)) if expected else b""
                assert got == expected, f"{path.name} step {i}: {req!r}"
            # nothing unexpected trails the last reply
            assert read(4096) == b""
        finally:
            close()
    finally:
        server.close()
    assert server.closed and not server.thread.is_alive()
