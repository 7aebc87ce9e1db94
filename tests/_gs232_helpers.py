"""Shared helpers for the GS-232 / emulator tests (transcripts, raw peers, leak checks)."""

from __future__ import annotations

import codecs
import os
import select
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

T0 = "2026-08-23T12:00:00+00:00"
# The suite's one time constant: how long a test polls for an effect before failing. It only
# bounds a failure; a passing test ends as soon as its condition holds.
WAIT_S = 10.0
# Simulated-motor speed of the real-I/O tier where the rate is not the subject.
SPEED = 150.0
TRANSCRIPTS = Path(__file__).parent / "data" / "transcripts"


@dataclass
class Transcript:
    profile: str
    rotator: str
    steps: list  # ("send", bytes, expected_bytes) | ("advance", seconds)


def unescape(text: str) -> bytes:
    return codecs.escape_decode(text.encode("ascii"))[0]


def load_transcript(path: Path) -> Transcript:
    profile, rotator, steps = "", "G-5500", []
    pending: bytes | None = None
    for raw in path.read_text().splitlines():
        if raw.startswith("# profile:"):
            profile = raw.split(":", 1)[1].strip()
        elif raw.startswith("# rotator:"):
            rotator = raw.split(":", 1)[1].strip()
        elif raw.startswith(">>"):
            assert pending is None, f"{path.name}: two requests without a reply line"
            pending = unescape(raw[3:])
        elif raw.startswith("<<"):
            assert pending is not None, f"{path.name}: reply without request"
            steps.append(("send", pending, unescape(raw[3:])))
            pending = None
        elif raw.startswith("@"):
            steps.append(("advance", float(raw[1:])))
    assert profile and steps
    return Transcript(profile, rotator, steps)


def replay_over_real_io(tr: Transcript, ctrl, clock, server, name: str, want_seen) -> None:
    """Play transcript ``tr`` against emulator ``ctrl`` served on ``server`` (a real TCP
    socket or pty), byte for byte: every reply exactly as recorded, nothing trailing.
    ``want_seen(seen, request)`` is how many commands the controller has taken once it has
    ``request`` (a silent command must be processed before the clock moves on)."""
    if server.url.startswith("socket://"):
        host, port = server.url.removeprefix("socket://").split(":")
        sock = socket.create_connection((host, int(port)), timeout=2)
        fileno, write, close = sock.fileno(), sock.sendall, sock.close

        def recv(n):
            return sock.recv(n)
    else:
        fd = os.open(server.url, os.O_RDWR | os.O_NOCTTY)
        fileno, close = fd, (lambda: os.close(fd))

        def write(b):
            os.write(fd, b)

        def recv(n):
            return os.read(fd, n)

    def read(n):
        r, _, _ = select.select([fileno], [], [], 0.1)
        return recv(n) if r else b""

    def read_exact(n: int, timeout_s: float = 2.0) -> bytes:
        out = b""
        end = time.monotonic() + timeout_s
        while len(out) < n and time.monotonic() < end:
            out += read(n - len(out))
        return out

    try:
        stray = getattr(ctrl, "power_on_byte", b"")
        if stray:
            assert read_exact(len(stray)) == stray
        for i, step in enumerate(tr.steps):
            if step[0] == "advance":
                clock.advance(step[1])
                continue
            _, req, expected = step
            want = want_seen(ctrl.commands_seen, req)
            write(req)
            assert wait_until(lambda w=want: ctrl.commands_seen >= w)
            got = read_exact(len(expected)) if expected else b""
            assert got == expected, f"{name} step {i}: {req!r}"
        assert read(4096) == b""      # nothing unexpected trails the last reply
    finally:
        close()


class RawPeer:
    """A tiny misbehaving 'controller' on a real TCP socket or pty: it reads requests and
    answers with whatever ``respond(request_bytes) -> bytes`` says."""

    def __init__(self, kind: str, respond):
        self.respond = respond
        self.received = bytearray()
        self._stop = threading.Event()
        if kind == "tcp":
            self._listen = socket.create_server(("127.0.0.1", 0))
            self.url = f"socket://127.0.0.1:{self._listen.getsockname()[1]}"
            self._fd = None
        else:
            import tty
            self._listen = None
            self._fd, self._slave = os.openpty()
            tty.setraw(self._slave)
            self.url = os.ttyname(self._slave)
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    # One I/O loop for both the socket and the pty fake, so the two behave alike.
    def _run(self) -> None:  # noqa: C901
        if self._listen is not None:
            self._listen.settimeout(0.05)
            conn = None
            while not self._stop.is_set() and conn is None:
                try:
                    conn, _ = self._listen.accept()
                except TimeoutError:
                    continue
            if conn is None:
                return
            rd, wr, fileno = conn.recv, conn.sendall, conn.fileno()
        else:
            fileno = self._fd

            def rd(n):
                return os.read(self._fd, n)

            def wr(b):
                os.write(self._fd, b)
        try:
            while not self._stop.is_set():
                r, _, _ = select.select([fileno], [], [], 0.05)
                if not r:
                    continue
                data = rd(4096)
                if not data:
                    return
                self.received += data
                out = self.respond(bytes(data))
                if out:
                    wr(out)
        except OSError:
            return
        finally:
            if self._listen is not None and conn is not None:
                conn.close()

    def close(self) -> None:
        self._stop.set()
        self.thread.join(2)
        if self._listen is not None:
            self._listen.close()
        else:
            os.close(self._fd)
            os.close(self._slave)


def wait_until(pred, timeout_s: float = WAIT_S, step_s: float = 0.01) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(step_s)
    return pred()


def advance_until(clock, pred, step_s: float = 1.0, timeout_s: float = WAIT_S) -> bool:
    """Like :func:`wait_until`, but jump the SimClock ``step_s`` simulated seconds forward
    between polls: for waits on the emulated motors that are not what a test is about. The
    motor model runs on simulated time, so a jump is the same slew seen sooner. Only once the
    controller has the command: a jump before it arrives would delay the start in simulated
    time (and put an open-loop estimate off)."""
    def check() -> bool:
        if pred():
            return True
        clock.skip(step_s)
        return False
    return wait_until(check, timeout_s)
